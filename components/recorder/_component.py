"""The ``recorder`` component: ports of the instances of its host kept in an MCAP file, next to the hardware."""

from __future__ import annotations

import asyncio
import logging
import math
from typing import Annotated, Any

from ..audio import AudioReader
from ..core import (
    Boolean, Component, ComponentHost, Double, Incremental, Out, OutPort, OutPortRuntime, OverBudget, String, Task,
    activity, function,
)
from ..recording import (
    DEFAULT_CHUNK_SIZE, AudioRecorder, ImageRecorder, JsonRecorder, NewRecording, PathRefused, QuotaReached,
    RecordingCounts, RecordingError, RecordQuotas, Recording, WriteFailed, create_recording,
)
from ._types import (
    ALREADY_RECORDING, BAD_RECORDING, NO_SUCH_PORT, OVER_BUDGET, PATH_REFUSED, WRITE_FAILED, PortCounts, PortList,
    RecorderStatus,
)

__all__ = ["Recorder"]

log = logging.getLogger(__name__)

#: Runtime seconds between two publications of the Status port while recording.
STATUS_PERIOD = 0.5
#: The least room a recording starts with: its first records and one chunk.
LEAST_BYTES = DEFAULT_CHUNK_SIZE + (64 << 10)
#: What a read gives while the component has withdrawn the port's data.
_WITHDRAWN = object()
#: How a recording until Stop that reached ``--max-recording-seconds`` ended.
_LONGEST = "over budget: --max-recording-seconds"
#: Whose requests and events a recording keeps (Start's ``events``).
EVENTS_OF = ("session", "all", "none")


class Recorder(Component, name="recorder", version="1.0"):
    """Records ports of the loaded instances into an MCAP file: audio with its frame indexes, head, cameras, any port.

    ``Start`` records the ports it is given (``instance/port``) into a new file under a directory
    the operator allowed (``--record-dir``), until ``Stop``, its ``duration`` or a full disk; the
    ``Status`` port says how far it is.  Every audio frame is recorded once, read by index, and so is
    every item of other numbered ports (binauloc's Estimates); other ports as their publications
    come, counting those replaced before they were read.

    A recording sent in a session ends with that session (its client stopped it, or went away
    and it expired after ``--session-idle``) unless ``Start`` asks it to outlive it; one sent in
    no session, or asked to outlive it, goes on when its client goes (it runs next to the
    hardware).  Every recording is bounded by the host's budgets: recordings at once
    (``--max-recordings``), runtime seconds (``--max-recording-seconds``), bytes of its file
    (``--max-recording-bytes``) and of its directory (``--max-record-dir-bytes``).  Files are
    created readable by their owner only (``--record-mode``), and replies name them within their
    record directory, never by their path on the host.

    Beside the ports, a recording keeps what was commanded when (``events``): the requests of the
    session that sent ``Start`` (by default), or of every session, with their input, status and
    times on the rig's clock, and the host's other events (``/events`` and ``/events/log``).
    """

    record = Task(doc="Follows the recorded ports and hands their data to the writer thread")
    Status = OutPort(RecorderStatus, doc="The recording: file, bytes and messages written, frames lost, per port")

    def __init__(self, host: ComponentHost, instance: str, argv: list[str] | None = None) -> None:
        super().__init__(host, instance, argv)
        self._recording: Recording | None = None
        self._path = ""
        self._began = 0.0
        self._ended = ""
        self._final = RecorderStatus()
        #: Set by Stop (or the end of the recording's session) while a recording runs (from the moment
        #: Start is sent); cleared when it has ended.
        self._stop = asyncio.Event()
        #: How the recording ends when _stop is set.
        self._stop_reason = "stopped"

    async def on_start(self) -> None:
        await super().on_start()
        self.Status.publish(RecorderStatus())

    # -- the ports to record ---------------------------------------------------------------------

    async def _port(self, name: str) -> tuple[OutPortRuntime[Any], dict[str, Any]]:
        """The out port *name* (``instance/port``) and its ``/info`` description.

        Raises:
            NO_SUCH_PORT: when there is no such instance or out port, or it is a multiple port.
        """
        instance, _, port = name.strip("/").partition("/")
        if not instance or not port or "/" in port:
            raise NO_SUCH_PORT(port=name, what="name a port as instance/port, e.g. kemarcapture/Port")
        try:
            peer = await self.host.peer(instance)
        except LookupError as exc:
            # With components of other processes, the finder's message says more (two hosts: NAME@HOST).
            what = str(exc) if self.host.finder is not None else f"no instance {instance!r} is loaded"
            raise NO_SUCH_PORT(port=name, what=what) from exc
        except Exception as exc:
            if self.host.finder is None:
                raise
            # An instance of another process that cannot be reached as asked (its host silent, no room).
            raise NO_SUCH_PORT(port=name, what=str(exc)) from exc
        described = next((p for p in peer.description()["ports"] if p["name"] == port), None)
        if described is None or described["dir"] != "out":
            outs = ", ".join(p["name"] for p in peer.description()["ports"] if p["dir"] == "out")
            raise NO_SUCH_PORT(port=name, what=f"{instance} has no out port {port!r} (out ports: {outs})")
        if described.get("kind") == "multiple":
            raise NO_SUCH_PORT(port=name, what=f"{name} is a multiple port: recording it is not supported")
        runtime = peer.port(port)
        assert isinstance(runtime, OutPortRuntime)
        return runtime, described

    async def _validate_start(self, path: str, ports: list[str], duration: float, outlive_session: bool,
                              events: str) -> None:
        running = [r for r in self.requests.running() if r.service.name == "Start"]
        if running:
            raise ALREADY_RECORDING(path=self._path or running[0].inputs["path"])
        if not ports:
            raise NO_SUCH_PORT(port="", what="name at least one port to record (instance/port)")
        if not (math.isfinite(duration) and duration >= 0):
            raise BAD_RECORDING(path=path, what=f"duration is a number of seconds, 0 or more (0: until Stop), "
                                                f"not {duration}")
        budgets = self.host.settings.budgets
        if duration > budgets.recording_seconds:
            flag = budgets.flag("recording_seconds")
            raise OVER_BUDGET(path=path, flag=flag, bytes=0, seconds=0.0,
                              what=f"a duration of {duration:g} s is longer than the {budgets.recording_seconds} s "
                                   f"of {flag}")
        if events not in EVENTS_OF:
            raise BAD_RECORDING(path=path, what=f"events is one of {', '.join(EVENTS_OF)}, not {events!r}")
        for name in ports:
            await self._port(name)

    # -- services ---------------------------------------------------------------------------------

    # Not a motion (decision 28): a recording goes on when the gateway that started it vanishes, unless it
    # belongs to a session of that gateway (on_session_end).
    @activity(task=record, validate=_validate_start,
              throws=(PATH_REFUSED, NO_SUCH_PORT, ALREADY_RECORDING, BAD_RECORDING, WRITE_FAILED, OVER_BUDGET))
    async def Start(
        self,
        path: Annotated[String, "The new file, ending in .mcap: relative to the allowed directory, or in it"],
        ports: Annotated[PortList, "The ports to record, as instance/port (kemarcapture/Port, kemar/currentState)"],
        duration: Annotated[Double, "Runtime seconds to record (0: until Stop, at most --max-recording-seconds)"]
        = 0.0,
        outlive_session: Annotated[Boolean, "Go on when the session that sent Start ends (its client stopped it or "
                                            "went away); by default the recording stops with it"] = False,
        events: Annotated[String, "Whose requests and events to record beside the ports: session (those of the "
                                  "session that sent Start, none if it was sent in none), all (every request of the "
                                  "host) or none"] = "session",
    ) -> Annotated[RecorderStatus, Out("status", "What was recorded, and how it ended")]:
        """Record ports into a new MCAP file until Stop, the duration, the end of its session, or a full disk.

        Ends done with what was recorded; a disk that fills up ends it in WRITE_FAILED, a budget of
        the host in OVER_BUDGET, and the file keeps what was written before, readable.
        """
        # (One Start runs at a time: _validate_start refuses a second.)
        start = next((r for r in self.requests.running() if r.service.name == "Start"), None)
        whose = None if events == "none" else "" if events == "all" else start.session if start else None
        try:
            return await self._record(path, ports, duration, whose)
        finally:
            # A Stop sent at any time while this Start ran (before its file was open too) was for it.
            self._stop.clear()
            self._stop_reason = "stopped"

    async def _record(self, path: str, ports: list[str], duration: float, whose: str | None) -> RecorderStatus:
        """Record *ports*, and the host's events of the session *whose* (``""``: all; None: none)."""
        followed = [(name, *await self._port(name)) for name in dict.fromkeys(ports)]
        try:
            running = self.host.ledgers.recordings.reserve(1, self.instance, f"a recording ({path})")
        except OverBudget as exc:
            raise OVER_BUDGET(path=path, flag=exc.flag, bytes=0, seconds=0.0,
                              what=f"{exc.held} recordings run on this host, the most {exc.flag} allows: stop one "
                                   f"first") from exc
        with running:
            created = await self._create(path)
            recording = Recording.open(created.stream, created.path, {
                "recorder": f"{self.instance} (aiogenomix recorder component)",
                "ports": ",".join(n for n, *_ in followed),
                "events": "none" if whose is None else f"session {whose}" if whose else "all",
                "clock": f"{type(self.clock).__name__} x{self.clock.scale:g}"}, quota=created.quota)
            self._recording, self._path, self._began, self._ended = recording, created.name, self.clock.now(), ""
            log.info("%s: recording %s into %s", self.instance, ", ".join(n for n, *_ in followed), created.path)
            tasks = [asyncio.create_task(self._follow(port, recording.add_port(name, described)),
                                         name=f"{self.instance} records {name}")
                     for name, port, described in followed]
            tasks.append(asyncio.create_task(self._publish_status(), name=f"{self.instance} status"))
            subscription = None if whose is None else self.host.events.subscribe(
                recording.add_host_events(whose), session=whose or None)
            ended = "stopped"
            try:
                ended = await self._until_the_end(recording, tasks, duration)
            except asyncio.CancelledError:
                ended = "interrupted"
                raise
            finally:
                if subscription is not None:
                    subscription.close()
                for task in tasks:
                    task.cancel()
                await asyncio.gather(*tasks, return_exceptions=True)
                counts = await asyncio.shield(self._close(recording, ended))
        self._raise_if_cut_short(recording, ended, counts)
        return self.status()

    async def _create(self, path: str) -> NewRecording:
        """The new recording file *path*, in the operator's directories, with its quota of bytes.

        Raises:
            PATH_REFUSED, BAD_RECORDING, OVER_BUDGET: no file is made.
        """
        settings = self.host.settings
        quotas = self.host.shared(RecordQuotas, lambda: RecordQuotas(settings.budgets))
        try:
            # The disk is part of the rig: a simulated clock waits for it (as for a device opening).
            with self.clock.holding():
                return await asyncio.to_thread(create_recording, path, settings.record_dirs, settings.record_mode,
                                               quotas=quotas, least=LEAST_BYTES)
        except PathRefused as exc:
            raise PATH_REFUSED(path=path, what=str(exc)) from exc
        except RecordingError as exc:
            raise BAD_RECORDING(path=path, what=str(exc)) from exc
        except OverBudget as exc:
            raise OVER_BUDGET(path=path, what=str(exc), flag=exc.flag, bytes=0, seconds=0.0) from exc

    def _raise_if_cut_short(self, recording: Recording, ended: str, counts: RecordingCounts) -> None:
        """Raise the exception of a recording a full disk or a budget ended.

        Raises:
            OVER_BUDGET: for a budget of the host.
            WRITE_FAILED: for the disk.
        """
        failure, seconds = recording.writer.failure, self.clock.now() - self._began
        if isinstance(failure, QuotaReached):
            raise OVER_BUDGET(path=self._path, what=str(failure.over), flag=failure.over.flag, bytes=counts.bytes,
                              seconds=seconds)
        if failure is not None:
            raise WRITE_FAILED(path=self._path, what=failure.strerror or str(failure), bytes=counts.bytes,
                               seconds=seconds)
        if ended == _LONGEST:
            budgets = self.host.settings.budgets
            flag = budgets.flag("recording_seconds")
            raise OVER_BUDGET(path=self._path, flag=flag, bytes=counts.bytes, seconds=seconds,
                              what=f"the recording reached the {budgets.recording_seconds} s of {flag} (a recording "
                                   f"until Stop ends there)")

    async def _until_the_end(self, recording: Recording, tasks: list[asyncio.Task[None]], duration: float) -> str:
        """Wait for Stop (or the session's end), the duration, a write failure or a follower's failure; say which."""
        ends: dict[asyncio.Future[Any], str] = {
            asyncio.ensure_future(self._stop.wait()): "stopped",
            asyncio.ensure_future(recording.writer.failed.wait()): "write failed",
        }
        if duration > 0:
            ends[asyncio.ensure_future(self.clock.sleep(duration))] = "duration"
        else:
            ends[asyncio.ensure_future(self.clock.sleep(self.host.settings.budgets.recording_seconds))] = _LONGEST
        try:
            done, _ = await asyncio.wait([*ends, *tasks], return_when=asyncio.FIRST_COMPLETED)
        finally:
            for waiter in ends:
                waiter.cancel()
        for task in tasks:
            if task in done and not task.cancelled() and task.exception() is not None:
                exc = task.exception()
                log.error("%s: %s failed", self.instance, task.get_name(), exc_info=exc)
                return f"failed: {type(exc).__name__}: {exc}"
        why = next((why for waiter, why in ends.items() if waiter in done), "stopped")
        return self._stop_reason if why == "stopped" else why

    async def _close(self, recording: Recording, ended: str) -> RecordingCounts:
        try:
            with self.clock.holding():
                counts = await recording.close(ended)
        except WriteFailed as exc:
            counts = recording.counts()
            budget = isinstance(recording.writer.failure, QuotaReached)
            ended = f"{'over budget' if budget else 'write failed'}: {exc.strerror or exc}"
        self._ended = ended
        self._final = self._status_of(recording, active=False)
        self._recording = None
        self.Status.publish(self._final)
        log.info("%s: %s ended (%s): %d bytes, %d messages, %d frames lost", self.instance, recording.path, ended,
                 counts.bytes, counts.messages, counts.lost_frames)
        return counts

    async def on_session_end(self, session: str, requests: list[Any]) -> None:
        """Stop a recording sent in *session* (which ended), unless its Start asked it to outlive it."""
        for request in requests:
            if request.service.name == "Start" and not request.inputs.get("outlive_session"):
                log.info("%s: the session %r that started %s ended: the recording stops", self.instance, session,
                         request.id)
                self._stop_reason = f"session {session} ended"
                self._stop.set()

    @function
    async def Stop(self) -> None:
        """Stop the recording and end its file (done when the file is complete; nothing to do when none runs)."""
        running = [r for r in self.requests.running() if r.service.name == "Start"]
        if running:
            self._stop.set()  # (none running: nothing to stop, and no later recording is stopped by it)
        for request in running:
            if request.task is not None:
                await asyncio.shield(asyncio.wait({request.task}))

    @function
    def GetStatus(self) -> Annotated[RecorderStatus, Out("status", "The recording now, or how the last one ended")]:
        """Where the recording is: file, bytes and messages written, frames lost, per port."""
        return self.status()

    def status(self) -> RecorderStatus:
        """The recording's status now (what the Status port publishes), or how the last one ended."""
        recording = self._recording
        return self._final if recording is None else self._status_of(recording, active=True)

    def _status_of(self, recording: Recording, *, active: bool) -> RecorderStatus:
        counts = recording.counts()
        return RecorderStatus(
            recording=active, path=self._path, elapsed=self.clock.now() - self._began, bytes=counts.bytes,
            messages=counts.messages, queued=counts.queued, lost_frames=counts.lost_frames,
            coalesced=counts.coalesced, unavailable=counts.unavailable, ended="" if active else self._ended,
            ports=[PortCounts(port=name, **values) for name, values in counts.ports.items()])

    async def _publish_status(self) -> None:
        while True:
            self.Status.publish(self.status())
            await self.clock.sleep(STATUS_PERIOD)

    # -- following the ports --------------------------------------------------------------------

    async def _room(self, recording: Recording) -> None:
        """Wait until the writer takes more (the clock of a simulated rig waits with it: the disk is part of it)."""
        writer = recording.writer
        if not writer.has_room():
            with self.clock.holding():
                await writer.wait_room()

    @staticmethod
    def _current(port: OutPortRuntime[Any], recorder: AudioRecorder | ImageRecorder | JsonRecorder) -> Any:
        """The port's data, or ``_WITHDRAWN`` while its component has withdrawn it (a sensor down): counted."""
        if port.withdrawn is not None:
            recorder.unavailable += 1
            return _WITHDRAWN
        return port.read()

    async def _follow(self, port: OutPortRuntime[Any], recorder: AudioRecorder | ImageRecorder | JsonRecorder) -> None:
        recording = self._recording
        assert recording is not None
        if isinstance(recorder, AudioRecorder):
            await self._follow_audio(port, recorder, recording)
            return
        # (A look, not a read: a withdrawn port is counted unavailable by the loop that reads it.)
        if isinstance(recorder, JsonRecorder) and port.withdrawn is None and isinstance(port.read(), Incremental):
            await self._follow_numbered(port, recorder, recording)
            return
        delivered = 0
        while True:
            await self._room(recording)
            if port.version <= delivered:
                await port.wait_published(delivered)
            version = port.version
            coalesced = version - delivered - 1 if delivered else 0
            delivered = version
            value = self._current(port, recorder)
            if value is not _WITHDRAWN:  # (else the next publication is current again)
                recorder.write(port.type.encode(value), coalesced=coalesced, rig_time=self.clock.wall())

    async def _follow_numbered(self, port: OutPortRuntime[Any], recorder: JsonRecorder,
                               recording: Recording) -> None:
        """Numbered data that is not audio (binauloc's Estimates): each item once, those after the last recorded.

        Each message holds the items a publication added (several when the writer was slow), from the
        newest held when the recording started; items the port no longer held are counted as coalesced.
        """
        current = self._current(port, recorder)
        since = max(0, current.index - int(getattr(current, "items_per_publication", 1))) \
            if isinstance(current, Incremental) else 0
        while True:
            await self._room(recording)
            value = self._current(port, recorder)
            if isinstance(value, Incremental):
                if value.index < since:
                    since = 0                      # numbered anew (a component started again)
                if value.index > since:
                    data, lost = value.since(since)
                    since = value.index
                    recorder.write(port.type.encode(data), coalesced=lost, rig_time=self.clock.wall())
                    continue
            # Nothing is awaited between the read above and this wait: no publication slips between them.
            await port.wait_published()

    async def _follow_audio(self, port: OutPortRuntime[Any], recorder: AudioRecorder, recording: Recording) -> None:
        """Every frame once: the items after the last one recorded, at each publication."""
        reader = AudioReader(port)
        started = port.withdrawn is None
        if started:
            reader.start_live()
        else:
            recorder.unavailable += 1
        while True:
            await self._room(recording)
            if port.withdrawn is not None:
                recorder.unavailable += 1
            else:
                if not started:
                    # Not current when the recording started: recorded from the publication that ends that.
                    reader.start_with_last_publication()
                    started = True
                try:
                    read = reader.read(self.clock.wall())
                except ValueError as exc:
                    raise RecordingError(f"{recorder.name}: {exc}") from None
                if read is not None:
                    recorder.add(read)
                    continue
            # Nothing is awaited between the read above and this wait: no publication slips between them.
            await port.wait_published()
