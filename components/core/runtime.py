"""The runtime the gateway hosts: request tracking, service specs, IDL type objects, lookup errors.

A component author needs none of this (see :mod:`aiogenomix.components.core`);
a host of components (the gateway, a remote component host, a test) does.
"""

from ._binary import BINARY_CONTENT_TYPE, BINARY_MAGIC, encode_binary
from ._budgets import MIB, size_text
from ._describe import describe
from ._engine import RequestEngine
from ._error_bodies import REMOTE_IO, error_body, message_of
from ._exceptions import (
    AmbiguousModule, ComponentError, InputError, NoSuchModule, NoSuchPort, NoSuchRequest, NoSuchService,
    PortUnavailable, RemoteHostGone, RemoteRefusal, RemoteUnreachable, RequestRunning, names_hint,
)
from ._heap import keep_heap_settled, settle_heap
from ._host import NoCapability, RemoteFinder, TooManyInstances
from ._instance import LoadedInstance, Placement
from ._ports import ComputedOutPortRuntime, PortSpec
from ._public import show_as_public as _show_as_public
from ._requests import SENDER_SCOPE, Request, RequestStatus, RequestTracker, parse_request_id
from ._setting_groups import (
    SETTINGS_ENTRY_POINTS, Setting, add_settings_arguments, amount_text, declared_settings, installed_settings_groups,
    parse_amount, settings_from,
)
from ._services import NO_DEFAULT, ParamSpec, ServiceDecorator, ServiceSpec
from ._tasks import TaskRuntime
from ._types import (
    ArrayType, EnumType, IdlType, OptionalType, Scalar, SequenceType, StringType, StructType, idl_type,
)

__all__ = [
    # Describing and hosting components, local or in other processes; running a component's requests
    "describe", "RequestEngine", "TooManyInstances", "RemoteFinder", "LoadedInstance", "Placement", "Request",
    "RequestStatus", "RequestTracker", "parse_request_id", "SENDER_SCOPE", "TaskRuntime",
    # What the runtime reads from declarations
    "ServiceSpec", "ParamSpec", "NO_DEFAULT", "ServiceDecorator", "PortSpec", "ComputedOutPortRuntime",
    # IDL type objects: description, decoding and encoding of data
    "IdlType", "Scalar", "StringType", "EnumType", "StructType", "SequenceType", "ArrayType", "OptionalType",
    "idl_type",
    # Port data on the wire: the binary form of reads and of remote ports
    "encode_binary", "BINARY_MAGIC", "BINARY_CONTENT_TYPE",
    # What the runtime refuses, and how a refusal reads on the wire
    "ComponentError", "InputError", "NoSuchModule", "NoSuchService", "NoSuchPort", "NoSuchRequest",
    "RequestRunning", "NoCapability", "PortUnavailable", "AmbiguousModule", "RemoteUnreachable", "RemoteHostGone",
    "RemoteRefusal", "error_body", "message_of", "REMOTE_IO", "names_hint",
    # Command lines made from settings groups (the gateway's and a component host's), other packages' groups
    "Setting", "declared_settings", "add_settings_arguments", "settings_from", "parse_amount", "amount_text",
    "installed_settings_groups", "SETTINGS_ENTRY_POINTS",
    # Amounts of bytes, as the budgets count and say them
    "MIB", "size_text",
    # A long-lived process's heap kept out of the garbage collector's full passes (the event loop's longest stalls)
    "keep_heap_settled", "settle_heap",
]

_show_as_public(globals(), __all__, __name__, __name__.rsplit(".", 1)[0])
