"""The ``replay`` component: the ports of a recording published again, under their names, at their recorded timing."""

from __future__ import annotations

import asyncio
import dataclasses
import logging
from collections.abc import Iterator
from typing import Annotated, Any

from ..core import (
    Boolean, Component, ComponentHost, Double, GenomException, LoadError, Out, OutPort, OutPortRuntime,
    String, ThrottledLog, ULongLong,
    activity, function, idl_struct,
)
from ..recording import PortMessage, RecordingError, RecordingReader, open_recording, replay_roots

__all__ = ["Replay", "ReplayStatus", "NOT_PLAYING"]

log = logging.getLogger(__name__)
#: A client may load an unfinished recording again and again: said a few times a minute.
_throttled = ThrottledLog(log)


@idl_struct("replay::status")
class ReplayStatus:
    """The recording being replayed and where the replay is."""

    file: Annotated[String, "The recording, as it was named at load (-file)"] = ""
    ports: Annotated[list[String], "The replayed ports, as this component names them"] = \
        dataclasses.field(default_factory=list)
    playing: Annotated[Boolean, "Whether Play runs"] = False
    published: Annotated[ULongLong, "Publications replayed by the last Play"] = 0
    position: Annotated[Double, "Seconds of the recording replayed (capture time since its first publication)"] = 0.0
    duration: Annotated[Double, "Seconds of the recording, first to last publication"] = 0.0


class NOT_PLAYING(GenomException):
    """The recording could not be read while it was replayed."""

    what: String


def _replay_names(ports: list[str]) -> dict[str, str]:
    """The name each recorded port (``instance/port``) is published under: its port name, unless two share it."""
    short = [p.split("/", 1)[1] for p in ports]
    return {p: (name if short.count(name) == 1 else p.replace("/", "_")) for p, name in zip(ports, short, strict=True)}


class Replay(Component, name="replay", version="1.0"):
    """Publishes the ports of a recording again, under their names, at their recorded timing.

    Load it with the recording: ``-file PATH`` (from a directory of ``--record-dir`` or
    ``--audio-files``).  Its ports are those the recording holds besides audio (replay audio as a
    capture device: ``mcap:PATH``), named like the recorded ones (``instance_port`` when two
    instances recorded the same port name), described and published as recorded.  ``Play``
    publishes them at their recorded timing (``speed`` times faster), ``Stop`` ends it.
    """

    usage_options = [*Component.usage_options,
                     ("-file PATH", "the recording to replay (in a directory of --record-dir or --audio-files)")]
    Status = OutPort(ReplayStatus, doc="The recording, its replayed ports and where the replay is")

    def __init__(self, host: ComponentHost, instance: str, argv: list[str] | None = None) -> None:
        super().__init__(host, instance, argv)
        if "-file" not in self.argv:
            raise LoadError("replay needs the recording to replay: load it with -file PATH")
        self.file = self.argv[self.argv.index("-file") + 1]
        self._recorded: dict[str, OutPortRuntime[Any]] = {}
        self._described: list[dict[str, Any]] = []
        self._description_replayed: dict[str, Any] | None = None
        self._names: dict[str, str] = {}
        self._span = (0.0, 0.0)

    async def on_start(self) -> None:
        await super().on_start()
        try:
            ports, span = await asyncio.to_thread(self._read_summary)
        except RecordingError as exc:
            raise LoadError(f"replay cannot read {self.file!r}: {exc}") from exc
        self._span = span
        self._names = _replay_names([p for p, _ in ports])
        for recorded, (described, doc) in ports:
            name = self._names[recorded]
            spec = OutPort.from_description({"name": name, "type": described,
                                             "doc": f"{doc} (replayed from {recorded})".strip()}, "recorded")
            self._recorded[name] = OutPortRuntime(spec, self)
            self._described.append({"name": name, "dir": "out", "kind": "simple", "type": described,
                                    "doc": spec.doc})
        self.Status.publish(self._status(0, 0.0, playing=False))

    def _reader(self) -> tuple[RecordingReader, str]:
        """The recording open for reading, and its full path (blocking: off the event loop).

        Raises:
            RecordingError: when it is outside the allowed directories, missing, or not a recording.
        """
        settings = self.host.settings
        stream, path = open_recording(self.file, replay_roots(settings.record_dirs, settings.audio_files))
        try:
            return RecordingReader(stream, repr(self.file)), path
        except BaseException:
            stream.close()
            raise

    def _read_summary(self) -> tuple[list[tuple[str, tuple[dict[str, Any], str]]], tuple[float, float]]:
        """The recording's non-audio ports with their types and docs, and its time span."""
        opened, _ = self._reader()
        with opened as reader:
            if reader.unfinished is not None:
                _throttled.warning("%s: %s", self.instance, reader.unfinished.said)
            ports = []
            for channel in reader.channels("port"):
                recorded = channel.metadata["aiogenomix.port"]
                ports.append((recorded, (reader.port_type(recorded), channel.metadata.get("aiogenomix.doc", ""))))
            statistics = reader.summary.statistics
            span = ((statistics.message_start_time * 1e-9, statistics.message_end_time * 1e-9)
                    if statistics is not None else (0.0, 0.0))
        return ports, span

    # -- the replayed ports, beside the declared ones ------------------------------------------

    def description(self) -> dict[str, Any]:
        """``/info``: the declared ports, then the replayed ones (known once started; then described once)."""
        declared = super().description()
        if not self._described:
            return declared
        if self._description_replayed is None:
            self._description_replayed = {**declared, "ports": [*declared["ports"], *self._described]}
        return self._description_replayed

    def port(self, name: str) -> Any:
        """A replayed port by its name, or a declared one."""
        recorded = self._recorded.get(name)
        return recorded if recorded is not None else super().port(name)

    def _status(self, published: int, position: float, *, playing: bool) -> ReplayStatus:
        # The name the client gave, never the file's path on this host.
        return ReplayStatus(file=self.file, ports=list(self._recorded), playing=playing, published=published,
                            position=position, duration=max(0.0, self._span[1] - self._span[0]))

    # -- services ---------------------------------------------------------------------------

    @activity(throws=(NOT_PLAYING,), interrupts=("Play",), progress="Status.position")
    async def Play(self, speed: Annotated[Double, "Replay this many times faster than recorded (1: as recorded)"]
                   = 1.0) -> Annotated[ULongLong, Out("published", "Publications replayed")]:
        """Publish the recorded ports again at their recorded timing, from the start to the end of the recording."""
        if not speed > 0:
            raise NOT_PLAYING(what=f"speed must be a positive number, not {speed}")
        try:
            with self.clock.holding():  # a simulated clock waits for the disk: publications keep their timing
                reader, _ = await asyncio.to_thread(self._reader)
        except RecordingError as exc:  # changed or removed since the load
            raise NOT_PLAYING(what=str(exc)) from exc
        messages = reader.publications()
        published, first_time, origin = 0, None, self.clock.now()
        try:
            while (message := await self._next(messages)) is not None:
                if first_time is None:
                    first_time = message.capture_time
                offset = message.capture_time - first_time
                await self.clock.sleep_until(origin + offset / speed)
                self._recorded[self._names[message.port]].publish(message.data)
                published += 1
                if published % 20 == 1:
                    self.Status.publish(self._status(published, offset, playing=True))
        except RecordingError as exc:
            raise NOT_PLAYING(what=str(exc)) from exc
        finally:
            await asyncio.to_thread(reader.close)
            self.Status.publish(self._status(published, self.Status.read().position, playing=False))
        return published

    async def _next(self, messages: Iterator[PortMessage]) -> PortMessage | None:
        with self.clock.holding():
            return await asyncio.to_thread(_next, messages)

    @function(interrupts=("Play",))
    def Stop(self) -> None:
        """Stop the replay (Play ends, interrupted); the ports keep their last publications."""


def _next(messages: Iterator[PortMessage]) -> PortMessage | None:
    return next(messages, None)
