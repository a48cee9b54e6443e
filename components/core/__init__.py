"""Write a GenoM3-like component: services, ports, tasks and exceptions declared with type hints.

What a component author uses lives here; the runtime that hosts components
(request tracking, service specs, IDL type objects) is :mod:`.runtime`.
``docs/writing_a_component.md`` walks a component from nothing to generated
client functions; ``components/demo`` is a complete one.
"""

from ._audio_stream import FULL_SCALE, AudioPiece, AudioRead, AudioStream
from ._budgets import Budgets, Ledger, Ledgers, OverBudget, Reservation
from ._chunked import Chunk, Chunked, ChunkedArray
from ._clock import Clock, ManualClock, RealClock, ScaledClock, VirtualClock
from ._component import Component
from ._events import (
    ComponentsOffered, Event, HostEvents, InstanceLoaded, InstanceUnloaded, RequestEvent, SessionEnded, Subscription,
)
from ._exceptions import (
    GenomException, disallowed, interrupted, no_such_activity, no_such_inport, no_such_outport, no_such_service,
    port_io, serialization, syserr, too_many_activities, unkex,
)
from ._genom_services import GenomServices
from ._host import ComponentHost, LoadError
from ._log_limits import ThrottledLog
from ._names import NAME_FORBIDDEN, forbidden_in_name
from ._json_schema import JsonSchemas, json_schema, schema_name
from ._kinds import (
    HeadReading, HeadState, Image, ImageReading, JointReading, JointStates, LaserScan, MemberNeed, Odometry,
    PlanarOdometry, PortKind, Pose, PoseReading, ScanReading, carried_by, member_at, seconds_of,
)
from ._setting_groups import SettingsGroup, at_least, positive, setting, tcp_port, whole_at_least
from ._settings import ClockSettings, HostSettings
from ._ports import ComputedOutPort, Incremental, InPort, InPortRuntime, OutPort, OutPortRuntime
from ._public import show_as_public as _show_as_public
from ._services import Out, activity, attribute, function, redeclare
from ._tasks import Task
from ._timestamp import Timestamp
from ._types import (
    Boolean, Bound, Char, DescribedType, Double, Float, Grid, Length, Long, LongLong, Octet, Short, String, ULong,
    ULongLong, Unit, UShort, array, idl_enum, idl_struct, optional, sequence, string,
)

__all__ = [
    # The component and what hosts it
    "Component", "ComponentHost", "HostSettings", "ClockSettings", "LoadError",
    # Settings groups: each setting's default, flag, unit, help and refusal declared once
    "SettingsGroup", "setting", "at_least", "positive", "whole_at_least", "tcp_port",
    # What happens on a host, as data: requests sent and ended, instances, sessions (host.events)
    "Event", "RequestEvent", "InstanceLoaded", "InstanceUnloaded", "ComponentsOffered", "SessionEnded",
    "HostEvents", "Subscription",
    # Bounds of what clients can make a component hold, and the log lines they can cause
    "Budgets", "OverBudget", "Ledger", "Ledgers", "Reservation", "ThrottledLog",
    # What a name a client gives may hold (session names, recording paths)
    "NAME_FORBIDDEN", "forbidden_in_name",
    # Services, and the genom3 standard services every component has (to redeclare one)
    "function", "activity", "attribute", "redeclare", "Out", "GenomServices",
    # Ports and tasks
    "OutPort", "InPort", "ComputedOutPort", "OutPortRuntime", "InPortRuntime", "Task",
    # Port data read piece by piece
    "Incremental", "Chunked", "Chunk", "ChunkedArray",
    # Data types
    "idl_struct", "idl_enum", "Bound", "Length", "Boolean", "Octet", "Char", "Short", "UShort", "Long", "ULong",
    "LongLong", "ULongLong", "Float", "Double", "String", "sequence", "array", "optional", "string", "Timestamp",
    # Units of numbers, and what the index of a sequence stands for
    "Unit", "Grid",
    # What a port carries (its kind, declared by its type), and each kind's reading of the data
    "PortKind", "MemberNeed", "carried_by", "member_at", "seconds_of",
    "AudioStream", "AudioRead", "AudioPiece", "FULL_SCALE", "HeadState", "HeadReading", "Image", "ImageReading",
    "LaserScan", "ScanReading", "Pose", "PoseReading", "Odometry", "PlanarOdometry", "JointStates", "JointReading",
    # The type of a port known by its description only (another process's, a recording's)
    "DescribedType",
    # JSON Schemas of /info types (for recordings, live views, API documents)
    "json_schema", "JsonSchemas", "schema_name",
    # Clocks
    "Clock", "RealClock", "ScaledClock", "ManualClock", "VirtualClock",
    # Exceptions: the base of declared ones, and the standard ::genom:: ones
    "GenomException", "interrupted", "too_many_activities", "unkex", "syserr", "no_such_service",
    "no_such_outport", "no_such_inport", "port_io", "serialization", "disallowed", "no_such_activity",
]

_show_as_public(globals(), __all__, __name__, __name__)
