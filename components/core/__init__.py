"""The GenoM3-like component runtime: declare services, ports, tasks and exceptions with type hints.

See ``components/demo`` for a complete component, and docs/protocol.md for
how a component is seen on the wire.
"""

from ._chunked import Chunk, Chunked, ChunkedArray
from ._clock import Clock, ManualClock, RealClock, ScaledClock
from ._component import Component
from ._describe import describe
from ._exceptions import (
    ComponentError, GenomException, InputError, NoSuchModule, NoSuchPort, NoSuchRequest, NoSuchService,
    RequestRunning, disallowed, interrupted, no_such_inport, no_such_outport, no_such_service, port_io,
    serialization, syserr, too_many_activities, unkex,
)
from ._host import ComponentHost, LoadError, RemoteFinder, TooManyInstances
from ._ports import Incremental, InPort, InPortRuntime, OutPort, OutPortRuntime
from ._requests import Request, RequestTracker
from ._services import NO_DEFAULT, Out, ParamSpec, ServiceSpec, activity, attribute, function
from ._tasks import Task, TaskRuntime
from ._timestamp import Timestamp
from ._types import (
    ArrayType, Boolean, Char, Double, EnumType, Float, IdlType, Long, LongLong, Octet, OptionalType,
    Scalar, SequenceType, Short, String, StringType, StructType, ULong, ULongLong, UShort, array,
    idl_enum, idl_struct, idl_type, optional, sequence, string,
)

__all__ = [
    # Components and their host
    "Component", "ComponentHost", "LoadError", "TooManyInstances", "RemoteFinder", "describe",
    # Declarations
    "function", "activity", "attribute", "Out", "Task", "OutPort", "InPort",
    # Runtime objects
    "Request", "RequestTracker", "ServiceSpec", "ParamSpec", "NO_DEFAULT", "TaskRuntime",
    "OutPortRuntime", "InPortRuntime", "Incremental", "Chunked", "Chunk", "ChunkedArray",
    # Clocks and time
    "Timestamp", "Clock", "RealClock", "ScaledClock", "ManualClock",
    # Types
    "IdlType", "Scalar", "StringType", "EnumType", "StructType", "SequenceType", "ArrayType",
    "OptionalType", "idl_type", "idl_struct", "idl_enum", "sequence", "array", "optional", "string",
    "Boolean", "Octet", "Char", "Short", "UShort", "Long", "ULong", "LongLong", "ULongLong", "Float",
    "Double", "String",
    # Exceptions
    "ComponentError", "InputError", "NoSuchModule", "NoSuchService", "NoSuchPort", "NoSuchRequest",
    "RequestRunning", "GenomException", "interrupted", "too_many_activities", "unkex", "syserr",
    "no_such_service", "no_such_outport", "no_such_inport", "port_io", "serialization", "disallowed",
]
