"""Port kinds: what a port's data is (audio, a head's state, a picture...), declared once by the type that carries it.

An IDL type says how data is shaped; its kind says what it means, so that the tools that show,
record and analyse data (the recording, its export, the live view, the localiser) know any
component's port without a table of type names.  A struct declares its kind with the members that
hold each part of it::

    @idl_struct("kemar::state", carries=HeadState(position="position", velocity="speed"))
    class KemarState: ...

Numbers are converted by the units their members declare (``Unit("deg")`` on ``position``: degrees
to radians); a member that declares none is taken in SI units, as ROS takes them.  ``/info`` gives
the kind as the type's ``carries`` (:meth:`PortKind.describe`), so a port known only by its
description (another process's, a recorded one) carries it too (:func:`carried_by`).  The kinds of
other packages are subclasses of :class:`PortKind` with a ``kind=`` name of their own; a package
names each in an ``aiogenomix.port_kinds`` entry point, so that a process that has not imported it
(an export of a recording) finds it by name (:meth:`PortKind.named`).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import logging
import math
from collections.abc import Mapping
from typing import Any, ClassVar, NamedTuple, Self

import numpy as np
import numpy.typing as npt

__all__ = [
    "PORT_KINDS", "PortKind", "MemberNeed", "carried_by", "member_at", "seconds_of", "HeadState", "HeadReading",
    "Image", "ImageReading", "LaserScan", "ScanReading", "Pose", "PoseReading", "Odometry", "PlanarOdometry",
    "JointStates", "JointReading",
]

Json = Mapping[str, Any]

log = logging.getLogger(__name__)

#: The entry point group through which other packages name their port kinds (name: the kind's name).
PORT_KINDS = "aiogenomix.port_kinds"

#: The factor from each unit a member may declare to the SI unit of its quantity.
UNITS: dict[str, dict[str, float]] = {
    "angle": {"rad": 1.0, "deg": math.pi / 180},
    "angular velocity": {"rad/s": 1.0, "deg/s": math.pi / 180},
    "length": {"m": 1.0, "cm": 0.01, "mm": 0.001},
    "velocity": {"m/s": 1.0, "cm/s": 0.01, "mm/s": 0.001},
}
_INTEGERS = {"octet", "short", "unsigned short", "long", "unsigned long", "long long", "unsigned long long"}
_NUMBERS = _INTEGERS | {"float", "double"}


def member_at(data: Any, path: str) -> Any:
    """The member *path* (``header.frame_id``: dotted through structs) of JSON-ready data; None when absent."""
    for part in path.split("."):
        if not isinstance(data, Mapping):
            return None
        data = data.get(part)
    return data


def seconds_of(stamp: Any) -> float | None:
    """POSIX seconds of a timestamp struct (``{tv_sec, tv_nsec}``) or a number of seconds; None when not one (or 0)."""
    if isinstance(stamp, Mapping) and "tv_sec" in stamp:
        seconds = float(stamp["tv_sec"]) + float(stamp.get("tv_nsec") or 0) * 1e-9
    elif isinstance(stamp, (int, float)) and not isinstance(stamp, bool):
        seconds = float(stamp)
    else:
        return None
    return seconds if seconds > 0 and math.isfinite(seconds) else None


def _number(value: Any) -> float:
    """A number of JSON data, where ``null`` stands for NaN (JSON has no NaN)."""
    return math.nan if value is None else float(value)


def _member(described: Json, path: str) -> Json | None:
    """The ``/info`` member entry (``{"name", "type", "unit"?}``) at *path* of the struct type *described*."""
    entry: Json | None = None
    for part in path.split("."):
        if described.get("kind") != "struct":
            return None
        entry = next((m for m in described.get("members", ()) if m.get("name") == part), None)
        if entry is None:
            return None
        described = entry.get("type") or {}
    return entry


@dataclasses.dataclass(frozen=True)
class MemberNeed:
    """What a kind asks of the member one of its fields names.

    Attributes:
        shape: ``number``, ``integer``, ``numbers`` (a sequence of numbers), ``string``, ``strings``,
            ``octets``, ``time`` (a timestamp struct or seconds) or ``struct``.
        quantity: The quantity a number is of (a key of :data:`UNITS`), converted to SI by its unit.
        optional: Whether the field may name no member (None).
    """

    shape: str
    quantity: str | None = None
    optional: bool = False

    def fits(self, described: Json) -> bool:
        """Whether a member of type *described* has this shape."""
        kind = described.get("kind")
        element = described.get("element") or {}
        if self.shape == "number":
            return kind in _NUMBERS
        if self.shape == "integer":
            return kind in _INTEGERS
        if self.shape == "numbers":
            return kind in ("sequence", "array") and element.get("kind") in _NUMBERS
        if self.shape == "strings":
            return kind in ("sequence", "array") and element.get("kind") == "string"
        if self.shape == "octets":
            return kind in ("sequence", "array") and element.get("kind") == "octet"
        if self.shape == "time":
            return kind in ("float", "double") or (kind == "struct" and _member(described, "tv_sec") is not None)
        return kind == self.shape


@dataclasses.dataclass(frozen=True, kw_only=True)
class PortKind:
    """What a port's data is, and where each part of it lies: the base of every kind.

    A kind is a frozen dataclass whose fields name members of the struct that carries it (or
    say how to read them); :meth:`bind` checks them against that struct and learns their units.
    Subclasses name themselves: ``@dataclass(frozen=True, kw_only=True) class HeadState(PortKind,
    kind="head_state")``, and say what their fields' members must be (:attr:`needs`).
    """

    #: The kind's name in ``/info`` (``audio``, ``head_state``...).
    kind: ClassVar[str] = ""
    #: What each field's member must be (fields not here are options, not members).
    needs: ClassVar[dict[str, MemberNeed]] = {}
    _kinds: ClassVar[dict[str, type[PortKind]]] = {}
    _not_installed: ClassVar[set[str]] = set()
    #: The factor from each field's unit to SI, learnt by bind().
    _scales: dict[str, float] = dataclasses.field(default_factory=dict, init=False, repr=False, compare=False)

    def __init_subclass__(cls, kind: str = "", **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if kind:
            known = PortKind._kinds.get(kind)
            if known is not None and known.__qualname__ != cls.__qualname__:
                raise TypeError(f"the port kind {kind!r} is {known.__module__}.{known.__qualname__} already")
            cls.kind = kind
            PortKind._kinds[kind] = cls

    @classmethod
    def known(cls) -> dict[str, type[PortKind]]:
        """The kinds of this process by name (those of the packages imported so far)."""
        return dict(PortKind._kinds)

    @classmethod
    def named(cls, kind: str) -> type[PortKind] | None:
        """The kind called *kind*: one imported, else another package's ``aiogenomix.port_kinds`` entry point.

        A recording or another process's port may carry the kind of a package that this process
        has not imported (``aiogenomix-record export`` of an outside component's recording): the
        package names the kind's class in an entry point of that name, imported here on first use.
        """
        known = PortKind._kinds.get(kind)
        if known is not None or not kind or kind in PortKind._not_installed:
            return known
        PortKind._not_installed.add(kind)  # looked for once: a kind no package names stays plain data
        for entry in importlib.metadata.entry_points(group=PORT_KINDS, name=kind):
            found = entry.load()
            if isinstance(found, type) and issubclass(found, PortKind) and found.kind == kind:
                return found
            log.warning("the %s entry point %s (%s) is not the PortKind %r: its ports are shown as plain data",
                        PORT_KINDS, entry.name, entry.value, kind)
        return None

    def describe(self) -> dict[str, Any]:
        """The ``carries`` object of ``/info``: ``{"kind": ..., field: member, ...}`` (None fields left out)."""
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.init}
        # A field left out names no member (None): readers that know the kind take it so.
        return {"kind": self.kind, **{k: list(v) if isinstance(v, tuple) else v for k, v in fields.items()
                                      if v is not None}}

    @classmethod
    def from_description(cls, carries: Json) -> PortKind | None:
        """The kind a ``carries`` object describes; None for a kind unknown here or a malformed one."""
        known = PortKind.named(str(carries.get("kind", "")))
        if known is None or not dataclasses.is_dataclass(known):
            return None
        fields = {f.name: str(f.type) for f in dataclasses.fields(known) if f.init}
        given: dict[str, Any] = {}
        for key, value in carries.items():
            if key not in fields:
                continue  # what a newer version says of the kind: this one does without it
            if isinstance(value, list):
                value = tuple(value)
            if not _fits(fields[key], value):
                return None
            given[key] = value
        try:
            return known(**given)
        except (TypeError, ValueError):
            return None

    def bind(self, described: Json) -> Self:
        """This kind as carried by the struct type *described*: its members checked, their units learnt.

        Raises:
            TypeError: naming the field and the member, when a member is missing or of another shape,
                or declares a unit that is not one of its quantity.
        """
        scales: dict[str, float] = {}
        for field, need in self.needs.items():
            path = getattr(self, field)
            if path is None:
                if need.optional:
                    continue
                raise TypeError(f"{self.kind} needs {field}: the member of {described.get('name')} that holds it")
            entry = _member(described, path)
            if entry is None or not need.fits(entry.get("type") or {}):
                raise TypeError(f"{type(self).__name__}({field}={path!r}): {described.get('name')} has no "
                                f"{need.shape} member {path!r}")
            if need.quantity is not None:
                unit = entry.get("unit")
                units = UNITS[need.quantity]
                default = next(iter(units))
                if unit is not None and unit not in units:
                    raise TypeError(f"{type(self).__name__}({field}={path!r}): {path} is in {unit}, not an "
                                    f"{need.quantity} ({', '.join(units)})")
                scales[field] = units[unit or default]
        bound = dataclasses.replace(self)
        object.__setattr__(bound, "_scales", scales)
        bound._bound(described)
        return bound

    def _bound(self, described: Json) -> None:
        """What a kind learns of its struct besides units (override: the audio's sample format)."""

    def scale(self, field: str) -> float:
        """The factor from the unit of *field*'s member to SI (1 before :meth:`bind`)."""
        return self._scales.get(field, 1.0)

    def number(self, data: Json, field: str) -> float:
        """The number *field* names in *data*, in SI units (NaN when absent or null)."""
        path = getattr(self, field)
        return math.nan if path is None else _number(member_at(data, path)) * self.scale(field)


def _fits(annotation: str, value: Any) -> bool:
    """Whether a value of a ``carries`` object fits the field annotated *annotation* (``str | None``...)."""
    if value is None:
        return "None" in annotation
    if annotation.startswith("tuple"):
        return isinstance(value, tuple) and all(isinstance(v, str) for v in value)
    if annotation == "int":
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, str) and "str" in annotation


def carried_by(described: Json) -> PortKind | None:
    """The kind an ``/info`` type description carries (bound to it), or None.

    None too for a kind this process does not know (a package not installed here) or a
    description that does not fit it: the port is then shown and recorded as plain data.
    """
    carries = described.get("carries")
    if not isinstance(carries, Mapping):
        return None
    kind = PortKind.from_description(carries)
    if kind is None:
        return None
    try:
        return kind.bind(described)
    except TypeError:
        return None


def _values(values: Any) -> Any:
    """A sequence member's values (an array, a list), or none when absent."""
    return () if values is None else values


def _numbers(values: Any) -> npt.NDArray[np.float64]:
    """A sequence of numbers as float64, JSON's ``null`` as NaN."""
    if isinstance(values, list):
        values = [math.nan if v is None else v for v in values]
    return np.asarray(_values(values), dtype=np.float64).reshape(-1)


def _frame(data: Json, path: str | None) -> str:
    return "" if path is None else str(member_at(data, path) or "")


class HeadReading(NamedTuple):
    """A head's state: its azimuth in radians (positive to the left), its speed in radians per second."""

    position: float
    velocity: float


@dataclasses.dataclass(frozen=True, kw_only=True)
class HeadState(PortKind, kind="head_state"):
    """A turning head: its azimuth (positive to the left) and speed; the live view and the recordings show it.

    Attributes:
        position: The member holding the azimuth.
        velocity: The member holding the angular speed (None: not carried).
    """

    position: str = "position"
    velocity: str | None = None

    needs: ClassVar[dict[str, MemberNeed]] = {"position": MemberNeed("number", "angle"),
                                        "velocity": MemberNeed("number", "angular velocity", optional=True)}

    def read(self, data: Json) -> HeadReading:
        """The head's state in *data*, in radians."""
        return HeadReading(self.number(data, "position"), self.number(data, "velocity"))


class ImageReading(NamedTuple):
    """A picture as ``sensor_msgs/Image`` and ``foxglove.RawImage`` hold it."""

    width: int
    height: int
    encoding: str
    step: int
    data: bytes | npt.NDArray[np.uint8]


@dataclasses.dataclass(frozen=True, kw_only=True)
class Image(PortKind, kind="image"):
    """A camera picture: ``height`` rows of ``step`` octets in an ``encoding`` (``rgba8``, ``mono8``...)."""

    width: str = "width"
    height: str = "height"
    encoding: str = "encoding"
    step: str = "step"
    data: str = "data"

    needs: ClassVar[dict[str, MemberNeed]] = {
        "width": MemberNeed("integer"), "height": MemberNeed("integer"), "encoding": MemberNeed("string"),
        "step": MemberNeed("integer"), "data": MemberNeed("octets")}

    def read(self, data: Json) -> ImageReading:
        """The picture in *data* (its pixels as they are: bytes or an array of octets)."""
        pixels = member_at(data, self.data)
        if not isinstance(pixels, (bytes, np.ndarray)):
            pixels = np.asarray(pixels if pixels is not None else (), dtype=np.uint8)
        return ImageReading(int(member_at(data, self.width) or 0), int(member_at(data, self.height) or 0),
                            str(member_at(data, self.encoding) or ""), int(member_at(data, self.step) or 0), pixels)


class ScanReading(NamedTuple):
    """A planar laser scan in radians and metres."""

    angle_min: float
    angle_max: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: npt.NDArray[np.float32]
    frame: str


@dataclasses.dataclass(frozen=True, kw_only=True)
class LaserScan(PortKind, kind="laser_scan"):
    """A planar laser's sweep: ranges from ``angle_min`` to ``angle_max`` (0 ahead, positive to the left)."""

    angle_min: str = "angle_min"
    angle_max: str = "angle_max"
    angle_increment: str = "angle_increment"
    range_min: str = "range_min"
    range_max: str = "range_max"
    ranges: str = "ranges"
    frame: str | None = "header.frame_id"

    needs: ClassVar[dict[str, MemberNeed]] = {
        "angle_min": MemberNeed("number", "angle"), "angle_max": MemberNeed("number", "angle"),
        "angle_increment": MemberNeed("number", "angle"), "range_min": MemberNeed("number", "length"),
        "range_max": MemberNeed("number", "length"), "ranges": MemberNeed("numbers", "length"),
        "frame": MemberNeed("string", optional=True)}

    def read(self, data: Json) -> ScanReading:
        """The scan in *data*, in radians and metres (``null`` ranges as NaN)."""
        values = (_numbers(member_at(data, self.ranges)) * self.scale("ranges")).astype(np.float32)
        return ScanReading(self.number(data, "angle_min"), self.number(data, "angle_max"),
                           self.number(data, "angle_increment"), self.number(data, "range_min"),
                           self.number(data, "range_max"), values, _frame(data, self.frame))


class PoseReading(NamedTuple):
    """A pose: a position in metres, an orientation as a quaternion ``(x, y, z, w)``, the frame it is in."""

    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]
    frame: str


@dataclasses.dataclass(frozen=True, kw_only=True)
class Pose(PortKind, kind="pose"):
    """A pose in a frame: a position (a struct of ``x``, ``y``, ``z``), an orientation (``x``, ``y``, ``z``, ``w``)."""

    position: str = "pose.position"
    orientation: str = "pose.orientation"
    frame: str | None = "header.frame_id"

    needs: ClassVar[dict[str, MemberNeed]] = {"position": MemberNeed("struct"), "orientation": MemberNeed("struct"),
                                        "frame": MemberNeed("string", optional=True)}

    def read(self, data: Json) -> PoseReading:
        """The pose in *data*."""
        at, turn = member_at(data, self.position) or {}, member_at(data, self.orientation) or {}
        return PoseReading((_number(at.get("x")), _number(at.get("y")), _number(at.get("z"))),
                           (_number(turn.get("x")), _number(turn.get("y")), _number(turn.get("z")),
                            _number(turn.get("w", 1.0))), _frame(data, self.frame))


@dataclasses.dataclass(frozen=True)
class PlanarOdometry:
    """A robot's pose in the room and its velocity in its own frame, as ROS and Foxglove define odometry.

    Attributes:
        x: Metres, room frame.
        y: Metres, room frame.
        yaw: Heading in radians, counter-clockwise from the room's x axis.
        forward: Velocity along the robot's x axis (ahead), m/s.
        leftward: Velocity along the robot's y axis (to its left), m/s.
        turn: Yaw rate, rad/s.
    """

    x: float
    y: float
    yaw: float
    forward: float
    leftward: float
    turn: float

    @property
    def orientation(self) -> tuple[float, float, float, float]:
        """The heading as a quaternion ``(x, y, z, w)`` about the vertical axis."""
        return 0.0, 0.0, math.sin(self.yaw / 2), math.cos(self.yaw / 2)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Odometry(PortKind, kind="odometry"):
    """A robot base on the floor: where it is, where it heads, how fast it goes.

    Attributes:
        velocity_frame: ``room`` when ``vx`` and ``vy`` are along the room's axes, ``body`` when along
            the robot's (ahead, to its left), as ROS's twist.
    """

    x: str = "x"
    y: str = "y"
    yaw: str = "yaw"
    vx: str = "vx"
    vy: str = "vy"
    turn: str = "turn"
    velocity_frame: str = "body"

    needs: ClassVar[dict[str, MemberNeed]] = {
        "x": MemberNeed("number", "length"), "y": MemberNeed("number", "length"), "yaw": MemberNeed("number", "angle"),
        "vx": MemberNeed("number", "velocity"), "vy": MemberNeed("number", "velocity"),
        "turn": MemberNeed("number", "angular velocity")}

    def __post_init__(self) -> None:
        if self.velocity_frame not in ("room", "body"):
            raise ValueError(f"velocity_frame is room or body, not {self.velocity_frame!r}")

    def read(self, data: Json) -> PlanarOdometry:
        """The odometry in *data*, its velocity in the robot's frame."""
        yaw = self.number(data, "yaw")
        vx, vy = self.number(data, "vx"), self.number(data, "vy")
        if self.velocity_frame == "room":
            cos, sin = math.cos(yaw), math.sin(yaw)
            vx, vy = cos * vx + sin * vy, -sin * vx + cos * vy
        return PlanarOdometry(self.number(data, "x"), self.number(data, "y"), yaw, vx, vy, self.number(data, "turn"))


class JointReading(NamedTuple):
    """Joints by name with their positions and velocities (radians or metres, as ROS's joint states)."""

    names: list[str]
    positions: npt.NDArray[np.float64]
    velocities: npt.NDArray[np.float64]
    frame: str


@dataclasses.dataclass(frozen=True, kw_only=True)
class JointStates(PortKind, kind="joint_states"):
    """A robot's joints: their names, and their positions and velocities in the same order."""

    names: str = "name"
    positions: str = "position"
    velocities: str | None = "velocity"
    frame: str | None = "header.frame_id"

    needs: ClassVar[dict[str, MemberNeed]] = {"names": MemberNeed("strings"), "positions": MemberNeed("numbers"),
                                        "velocities": MemberNeed("numbers", optional=True),
                                        "frame": MemberNeed("string", optional=True)}

    def read(self, data: Json) -> JointReading:
        """The joints in *data*."""
        velocities = member_at(data, self.velocities) if self.velocities is not None else None
        return JointReading([str(n) for n in _values(member_at(data, self.names))],
                            _numbers(member_at(data, self.positions)), _numbers(velocities), _frame(data, self.frame))
