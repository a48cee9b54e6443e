"""The runtime the gateway hosts: request tracking, service specs, IDL type objects, lookup errors.

A component author needs none of this (see :mod:`aiogenomix.components.core`);
a host of components (the gateway, a remote component host, a test) does.
"""

from ._describe import describe
from ._exceptions import (
    ComponentError, InputError, NoSuchModule, NoSuchPort, NoSuchRequest, NoSuchService, PortUnavailable,
    RequestRunning,
)
from ._host import NoCapability, RemoteFinder, TooManyInstances
from ._ports import ComputedOutPortRuntime, PortSpec
from ._public import show_as_public as _show_as_public
from ._requests import Request, RequestStatus, RequestTracker
from ._services import NO_DEFAULT, ParamSpec, ServiceDecorator, ServiceSpec
from ._tasks import TaskRuntime
from ._types import (
    ArrayType, EnumType, IdlType, OptionalType, Scalar, SequenceType, StringType, StructType, idl_type,
)

__all__ = [
    # Describing and hosting components
    "describe", "TooManyInstances", "RemoteFinder", "Request", "RequestStatus", "RequestTracker", "TaskRuntime",
    # What the runtime reads from declarations
    "ServiceSpec", "ParamSpec", "NO_DEFAULT", "ServiceDecorator", "PortSpec", "ComputedOutPortRuntime",
    # IDL type objects: description, decoding and encoding of data
    "IdlType", "Scalar", "StringType", "EnumType", "StructType", "SequenceType", "ArrayType", "OptionalType",
    "idl_type",
    # What the runtime refuses
    "ComponentError", "InputError", "NoSuchModule", "NoSuchService", "NoSuchPort", "NoSuchRequest",
    "RequestRunning", "NoCapability", "PortUnavailable",
]

_show_as_public(globals(), __all__, __name__, __name__.rsplit(".", 1)[0])
