"""The live view in Foxglove and Lichtblick: the loaded instances' ports, served behind the gateway's door.

``--foxglove PORT`` starts the view's WebSocket server (``_foxglove_server``: the Foxglove
WebSocket protocol, under both of its names, ``foxglove.websocket.v1`` and ``foxglove.sdk.v1``)
beside the gateway, admitting viewers as the gateway admits requests: its Host and Origin rules
and its token (decision 0036).  Every out port of every loaded instance is a channel, added
when the instance loads and withdrawn when it unloads, in the type Foxglove's panels show,
encoded by the Foxglove SDK's message types.  What a port is, its type says (its port kind, the
``carries`` of ``/info``), for any component's port, another package's too:

* a head's state (:class:`~aiogenomix.components.core.HeadState`, ``kemar``'s ``currentState``):
  ``foxglove.JointStates``, joint ``head_yaw`` in radians;
* pictures: ``foxglove.RawImage``; laser scans: ``foxglove.LaserScan``; odometry:
  ``foxglove.Odometry``; poses: ``foxglove.PoseInFrame``; joint states: ``foxglove.JointStates``;
* audio (:class:`~aiogenomix.components.core.AudioStream`: ``capture``, ``kemarcapture``, ``bass``,
  any component's audio): ``foxglove.RawAudio``, whose only format is ``pcm-s16``: each sample is
  shown by its upper 16 bits (exactly what a 16-bit sound card captured: our captures left-justify
  samples into 32 bits), every chunk once, read by the audio library's reader;
* any other port: its JSON with its JSON Schema, as ``/read`` gives it.
* and the host's events on ``/events`` (:meth:`FoxgloveView.show_event`): ``foxglove.Log``, a
  line a request sent or ended (its id, service, input, status, output or exception), an unload,
  a session's end, at the rig's time, as the recorder's log lines.

A port is read and encoded only while a viewer subscribes to its channel, once for all of them.
Each viewer is served at its own pace within its send budget (``_foxglove_viewer``): publishing
never waits for a viewer, and the gateway's own clients never wait for the view.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import orjson

from ..components.core import (
    AudioStream, Clock, Event, HeadState, Image, JointStates, LaserScan, Odometry, OutPortRuntime, OverBudget, PortKind,
    Pose, json_schema,
)
from ..components.core.runtime import MIB, LoadedInstance, PortUnavailable, RemoteUnreachable
from ..components.recording import log_line, stamp_of
from ._door import Door
from ._foxglove_server import LiveChannel, LiveViewServer, protobuf_schema

if TYPE_CHECKING:
    # The audio library (its scenes, on scipy) is imported when an audio port is first shown, not with the
    # gateway: it doubled a gateway's resident memory (75 to 150 MB) for every deployment.
    from ..components.audio import AudioReader

__all__ = ["FoxgloveView", "FoxgloveUnavailable", "EVENTS_TOPIC"]

#: The channel of the host's events.
EVENTS_TOPIC = "/events"

log = logging.getLogger(__name__)

_NUMPY = orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS
Json = Mapping[str, Any]


class FoxgloveUnavailable(RuntimeError):
    """The Foxglove SDK is not installed (``pip install "aiogenomix[foxglove]"``), or the view cannot listen."""


def _stamp(data: Json, fallback: float) -> float:
    """The capture time the data carries, as the recording reads it; *fallback* when it carries none."""
    return stamp_of(data) or fallback


class _Shown:
    """One port shown in the view: its channel, and how its data becomes a message's bytes (audio: its reader)."""

    def __init__(self, channel: LiveChannel, encode: Callable[[Json, float], bytes] | None,
                 audio: AudioReader | None = None) -> None:
        self.channel = channel
        self.encode = encode
        self.audio = audio


class FoxgloveView:
    """The live view of a gateway, showing the ports of its loaded instances in Foxglove and Lichtblick.

    Args:
        address: The address to bind (the loopback address unless the operator says otherwise).
        port: The TCP port (0 picks a free one).
        door: The gateway's door: viewers are admitted by its rules and token.
        name: The server's name, shown by the viewer.
        clock: The rig's clock, which stamps data that carries no time (``bass``'s audio, pictures)
            as the rig stamps the rest (default: this machine's time).
        max_viewers: How many viewers may be connected at once (``--max-viewers``).
        viewer_bytes: The most bytes one viewer may hold unsent (``--max-viewer-bytes``).
    """

    def __init__(self, address: str, port: int, door: Door, name: str = "aiogenomix", clock: Clock | None = None,
                 max_viewers: int = 8, viewer_bytes: int = 32 * MIB) -> None:
        self.address, self.requested_port, self.name = address, port, name
        self._wall: Callable[[], float] = clock.wall if clock is not None else time.time
        self._fox: Any = None
        self._server = LiveViewServer(door, name, max_viewers, viewer_bytes)
        self._started = False
        self._followers: dict[str, list[asyncio.Task[None]]] = {}
        self._channels: dict[str, list[LiveChannel]] = {}
        self._events: LiveChannel | None = None

    @property
    def port(self) -> int:
        """The TCP port the server listens on (0 before :meth:`start`)."""
        return self._server.port

    async def start(self, instances: Mapping[str, LoadedInstance]) -> None:
        """Start the server and show the ports of *instances*.

        Raises:
            FoxgloveUnavailable: when the SDK is missing or the server cannot listen.
        """
        try:
            import foxglove
        except ImportError as exc:
            raise FoxgloveUnavailable('the Foxglove view needs the Foxglove SDK: pip install "aiogenomix[foxglove]"'
                                      ) from exc
        self._fox = foxglove
        try:
            await self._server.start(self.address, self.requested_port)
        except OSError as exc:
            raise FoxgloveUnavailable(f"the Foxglove view cannot listen on {self.address}:{self.requested_port}: "
                                      f"{exc.strerror or exc}") from exc
        self._started = True
        log.info("Foxglove view listening on ws://%s:%d", self.address, self.port)
        schema = foxglove.messages.Log.get_schema()
        self._events = self._server.add_channel(EVENTS_TOPIC, "protobuf", schema.name, schema.encoding,
                                                protobuf_schema(schema.data), latest_only=False)
        for component in instances.values():
            self.show(component)

    async def stop(self) -> None:
        """Stop following the ports, withdraw the channels, close the viewers, stop the server (idempotent)."""
        for instance in list(self._followers):
            await self.hide(instance)
        self._started = False
        await self._server.stop()

    def show_event(self, event: Event) -> None:
        """Show one of the host's events on ``/events`` (a subscriber of ``host.events``: it never blocks)."""
        channel = self._events
        if channel is None or not self._started or not channel.watched:
            return
        record = event.record()
        fox = self._fox
        level = fox.messages.LogLevel.Error if record.get("status") == "error" else fox.messages.LogLevel.Info
        message = fox.messages.Log(timestamp=_time(fox, event.time), level=level, message=log_line(record),
                                   name=str(record.get("instance") or "aiogenomix"), file="", line=0)
        self._server.publish(channel, int(event.time * 1e9), message.encode())

    # -- instances come and go ------------------------------------------------------------------

    def show(self, component: LoadedInstance) -> None:
        """Add a channel for each out port of *component* (a loaded instance) and follow it.

        A port the view cannot show is left out (and logged): the load it follows goes on.
        """
        try:
            self._show(component)
        except Exception:
            log.exception("the Foxglove view cannot show %s", component.instance)

    def _show(self, component: LoadedInstance) -> None:
        if not self._started or component.instance in self._followers:
            return
        tasks, channels = [], []
        for described in component.description().get("ports", []):
            if described.get("dir") != "out" or described.get("kind") == "multiple":
                continue
            port = component.port(described["name"])
            if not isinstance(port, OutPortRuntime):
                continue
            topic = f"/{component.instance}/{described['name']}"
            shown = self._channel_for(topic, port, described)
            channels.append(shown.channel)
            tasks.append(asyncio.create_task(self._follow(port, shown), name=f"foxglove {topic}"))
        self._followers[component.instance] = tasks
        self._channels[component.instance] = channels

    async def hide(self, instance: str) -> None:
        """Close the channels of an unloaded instance."""
        tasks = self._followers.pop(instance, [])
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        self._server.remove_channels(self._channels.pop(instance, []))

    # -- how each kind of port is shown -------------------------------------------------------

    def _typed(self, topic: str, message: Any, make: Callable[[Json, float], Any] | None,
               audio: AudioReader | None = None) -> _Shown:
        """A port shown as one of Foxglove's message types (protobuf, with the SDK's schema)."""
        schema = message.get_schema()
        channel = self._server.add_channel(topic, "protobuf", schema.name, schema.encoding,
                                           protobuf_schema(schema.data), latest_only=audio is None)
        encode = None if make is None else (lambda data, stamp: make(data, stamp).encode())
        return _Shown(channel, encode, audio)

    def _channel_for(self, topic: str, port: OutPortRuntime[Any], described: Json) -> _Shown:
        kind = port.type.carries
        if isinstance(kind, AudioStream):
            from ..components.audio import AudioReader  # see the import at the top

            return self._typed(topic, self._fox.messages.RawAudio, None, audio=AudioReader(port))
        shown = None if kind is None else _FOXGLOVE.get(type(kind))
        if kind is not None and shown is not None:
            message, convert = shown
            fox = self._fox

            def make(data: Json, stamp: float) -> Any:
                return convert(fox, kind, data, stamp, described)
            return self._typed(topic, getattr(fox.messages, message), make)
        schema = json_schema(described["type"], title=topic, doc=str(described.get("doc") or ""))
        name = str(described["type"].get("name", "")) or topic
        channel = self._server.add_channel(topic, "json", name, "jsonschema", orjson.dumps(schema).decode())
        return _Shown(channel, None)

    async def _follow(self, port: OutPortRuntime[Any], shown: _Shown) -> None:
        delivered = port.version
        channel = shown.channel
        subscribed: asyncio.Future[Any] | None = None
        try:
            while True:
                if port.version <= delivered and not channel.subscribed.is_set():
                    if subscribed is None or subscribed.done():
                        subscribed = asyncio.ensure_future(channel.subscribed.wait())
                    # The next publication, or a new viewer (who gets the current data at once).
                    await asyncio.wait([port.next_publication(), subscribed], return_when=asyncio.FIRST_COMPLETED)
                    continue
                channel.subscribed.clear()
                delivered = port.version
                if not channel.watched or (port.version == 0 and shown.audio is None):
                    if shown.audio is not None:
                        shown.audio.since = None  # nobody watches: nothing read, nothing encoded
                    continue
                now = self._wall()
                try:
                    if shown.audio is not None:
                        self._send_audio(channel, shown.audio, now)
                        continue
                    value = port.read()
                except (PortUnavailable, RemoteUnreachable, OverBudget):
                    continue  # not current (a sensor down, a silent host): shown again at the next publication
                data = port.type.encode(value)
                stamp = _stamp(data, now) if isinstance(data, Mapping) else now
                payload = shown.encode(data, stamp) if shown.encode is not None else orjson.dumps(data, option=_NUMPY)
                self._server.publish(channel, int(stamp * 1e9), payload)
        except asyncio.CancelledError:
            raise
        except Exception:
            log.exception("the Foxglove view stopped showing %s", channel.topic)
        finally:
            if subscribed is not None:
                subscribed.cancel()

    def _send_audio(self, channel: LiveChannel, reader: AudioReader, now: float) -> None:
        """Send the audio published since the last send (a new viewer: from the newest publication's)."""
        if reader.since is None:
            reader.start_with_last_publication()
        try:
            read = reader.read(now)
        except ValueError:
            log.debug("the Foxglove view skips a read of %s that is not whole chunks", channel.topic)
            return
        if read is None or not read.pieces or not read.rate:
            return
        # pcm-s16 is what RawAudio carries: the upper 16 bits of each left-justified int32 sample.
        samples = (read.frames >> 16).astype("<i2")
        fox = self._fox
        message = fox.messages.RawAudio(timestamp=_time(fox, read.pieces[0].stamp), data=samples.tobytes(),
                                        format="pcm-s16", sample_rate=read.rate, number_of_channels=read.channels)
        self._server.publish(channel, int(now * 1e9), message.encode())


def _time(fox: Any, seconds: float) -> Any:
    whole = math.floor(seconds)
    return fox.messages.Timestamp(sec=int(whole), nsec=min(999_999_999, int(round((seconds - whole) * 1e9))))


def _head(fox: Any, kind: HeadState, data: Json, stamp: float, described: Json) -> Any:
    state = kind.read(data)  # radians, as the recording's JointState
    messages = fox.messages
    return messages.JointStates(timestamp=_time(fox, stamp), joints=[messages.JointState(
        name="head_yaw", position=state.position, velocity=state.velocity)])


def _joints(fox: Any, kind: JointStates, data: Json, stamp: float, described: Json) -> Any:
    joints = kind.read(data)
    messages = fox.messages
    velocities = joints.velocities if len(joints.velocities) == len(joints.names) else [math.nan] * len(joints.names)
    return messages.JointStates(timestamp=_time(fox, stamp), joints=[
        messages.JointState(name=name, position=float(p), velocity=float(v))
        for name, p, v in zip(joints.names, joints.positions, velocities, strict=False)])


def _image(fox: Any, kind: Image, data: Json, stamp: float, described: Json) -> Any:
    picture = kind.read(data)
    raw = picture.data.tobytes() if isinstance(picture.data, np.ndarray) else bytes(picture.data)
    return fox.messages.RawImage(timestamp=_time(fox, stamp), frame_id=str(described["name"]), width=picture.width,
                                 height=picture.height, encoding=picture.encoding, step=picture.step, data=raw)


def _scan(fox: Any, kind: LaserScan, data: Json, stamp: float, described: Json) -> Any:
    scan = kind.read(data)
    return fox.messages.LaserScan(timestamp=_time(fox, stamp), frame_id=scan.frame, start_angle=scan.angle_min,
                                  end_angle=scan.angle_max, ranges=[float(r) for r in scan.ranges])


def _odometry(fox: Any, kind: Odometry, data: Json, stamp: float, described: Json) -> Any:
    # foxglove.Odometry's velocities are in body_frame_id, as the recording's nav_msgs/Odometry.
    moved = kind.read(data)
    messages = fox.messages
    pose = messages.Pose(position=messages.Vector3(x=moved.x, y=moved.y, z=0),
                         orientation=messages.Quaternion(**dict(zip("xyzw", moved.orientation, strict=True))))
    return messages.Odometry(timestamp=_time(fox, stamp), frame_id="map", body_frame_id="base_footprint", pose=pose,
                             linear_velocity=messages.Vector3(x=moved.forward, y=moved.leftward, z=0),
                             angular_velocity=messages.Vector3(x=0, y=0, z=moved.turn))


def _pose(fox: Any, kind: Pose, data: Json, stamp: float, described: Json) -> Any:
    pose = kind.read(data)
    messages = fox.messages
    return messages.PoseInFrame(
        timestamp=_time(fox, stamp), frame_id=pose.frame,
        pose=messages.Pose(position=messages.Vector3(**dict(zip("xyz", pose.position, strict=True))),
                           orientation=messages.Quaternion(**dict(zip("xyzw", pose.orientation, strict=True)))))


#: How each kind is shown: the Foxglove message type, and the conversion of the port's data into it.
_FOXGLOVE: dict[type[PortKind], tuple[str, Callable[[Any, Any, Json, float, Json], Any]]] = {
    HeadState: ("JointStates", _head),
    JointStates: ("JointStates", _joints),
    Image: ("RawImage", _image),
    LaserScan: ("LaserScan", _scan),
    Odometry: ("Odometry", _odometry),
    Pose: ("PoseInFrame", _pose),
}
