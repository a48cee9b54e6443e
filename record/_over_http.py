"""Recording a gateway's ports over HTTP: every audio frame by index, other ports as their watch delivers them.

The gateway is any aiogenomix gateway, on this machine or another: the recording is made
with its public protocol (``/info``, ``read?since=``, ``watch?since=``, ``session/listen``)
through the Python client, and written by the recording library as the ``recorder``
component writes it.  Data that carries no time (``bass``'s audio, pictures) is stamped with
the gateway's clock as this machine estimates it (:class:`RigClock`), as the component stamps
it with the rig's.  Only here are a session's request events recorded: components see no
sessions.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import Callable, Sequence
from typing import Any

from ..clients import AsyncClient, ModuleUnloaded, NotFound
from ..components.recording import (
    AudioRecorder, ImageRecorder, Recording, RecordingCounts, RecordingError, WriteFailed, create_recording, stamp_of,
)
from ._rig_clock import RigClock

__all__ = ["record_over_http", "PortNotFound"]

#: A ``since=`` beyond every item: the read answers the port's newest index and nothing else.
_BEYOND = 2**62


class PortNotFound(RecordingError):
    """A port named on the command line that the gateway does not have."""


async def _describe(client: AsyncClient, name: str) -> tuple[str, str, dict[str, Any]]:
    """``(instance, port, /info description)`` of the out port *name*.

    Raises:
        PortNotFound: for an instance or out port the gateway does not have.
    """
    instance, _, port = name.strip("/").partition("/")
    if not instance or not port or "/" in port:
        raise PortNotFound(f"{name!r}: name a port as INSTANCE/PORT, e.g. kemarcapture/Port")
    try:
        module = await client.module(instance)
    except NotFound as exc:
        raise PortNotFound(f"{name}: no instance {instance!r} is loaded on {client.url}") from exc
    ports = module.__info__.get("ports", [])
    described = next((p for p in ports if p["name"] == port and p.get("dir", "out") == "out"), None)
    if described is None:
        outs = ", ".join(p["name"] for p in ports if p.get("dir", "out") == "out")
        raise PortNotFound(f"{name}: {instance} has no out port {port!r} (out ports: {outs})")
    if described.get("kind") == "multiple":
        raise PortNotFound(f"{name} is a multiple port: recording it is not supported")
    return instance, port, dict(described)


async def _newest_index(client: AsyncClient, instance: str, port: str, recorder: AudioRecorder) -> int:
    """The newest item of an audio port now (its chunk or frame index), read without moving any data."""
    module = await client.module(instance)
    wrapped = await getattr(module, port)(since=_BEYOND, raw=True)
    return recorder.index_of(wrapped[port])


async def _follow_audio(client: AsyncClient, instance: str, port: str, recorder: AudioRecorder,
                        recording: Recording, rig: RigClock) -> None:
    """Every frame once: a watch of the items after the newest one when the recording started."""
    recorder.start_at(await _newest_index(client, instance, port, recorder))
    while True:
        async for event in client.watch(instance, port, since=recorder.since):
            rig_time = await rig.now()  # as received: the rig's time of the read (bass's audio carries none)
            newest = recorder.index_of(event.data)
            if recorder.restarted(newest):
                break  # a new capture: watched again from its first chunk
            recorder.write(event.data, lost=event.lost, rig_time=rig_time)
            # A full queue leaves the watch unread: the gateway counts what its window loses meanwhile.
            await recording.writer.wait_room()
        else:
            return


async def _follow(client: AsyncClient, instance: str, port: str, recording: Recording,
                  description: dict[str, Any], rig: RigClock) -> None:
    recorder = recording.add_port(f"{instance}/{port}", description)
    try:
        if isinstance(recorder, AudioRecorder):
            await _follow_audio(client, instance, port, recorder, recording, rig)
            return
        async for event in client.watch(instance, port):
            # The rig's time, for data that does not say when it was captured (pictures, stamp-less JSON).
            untimed = isinstance(recorder, ImageRecorder) or stamp_of(event.data) is None
            recorder.write(event.data, coalesced=event.lost, rig_time=await rig.now() if untimed else 0.0)
            await recording.writer.wait_room()
    except ModuleUnloaded:
        return  # the instance went away: the other ports go on


async def _follow_session(client: AsyncClient, recording: Recording, session: str) -> None:
    events = recording.add_events(session)
    async for event in client.session_events(session):
        events.write(event.event, event.data)
        await recording.writer.wait_room()


async def record_over_http(url: str, ports: Sequence[str], output: str, *, duration: float | None = None,
                           session: str | None = None, token: str | None = None,
                           stop: asyncio.Event | None = None,
                           progress: Callable[[RecordingCounts, float], None] | None = None,
                           progress_period: float = 0.5) -> tuple[str, RecordingCounts, str]:
    """Record *ports* (``instance/port``) of the gateway at *url* into the new file *output*.

    Args:
        url: The gateway (``http://host:port`` or ``host:port``).
        ports: The ports to record.
        output: The new MCAP file (never overwritten).
        duration: Seconds to record (None: until *stop*).
        session: Also record this session's events.
        token: The gateway's token.
        stop: Set it to end the recording (Ctrl-C).
        progress: Called with the counts and the elapsed seconds every *progress_period* seconds.
        progress_period: Seconds between two calls of *progress*.

    Returns:
        The file's full path, the final counts, and how it ended (``stopped``, ``duration``, or why).

    Raises:
        PortNotFound: for a port the gateway does not have (no file is made).
        RecordingError: when the file cannot be made.
        WriteFailed: when the file could not be written whole (it keeps what was written, readable).
        GenomixError: when the gateway cannot be reached or refuses.
    """
    stop = stop or asyncio.Event()
    async with AsyncClient(url, token=token) as client:
        described = [await _describe(client, name) for name in dict.fromkeys(ports)]
        rig = RigClock(client)
        await rig.now()
        created = await asyncio.to_thread(create_recording, output, None)
        path = created.path
        recording = Recording.open(created.stream, path, {
            "recorder": "aiogenomix-record (over HTTP)", "gateway": client.url,
            "ports": ",".join(f"{i}/{p}" for i, p, _ in described), "clock": rig.kind,
            **({"session": session} if session else {})})
        tasks = [asyncio.create_task(_follow(client, instance, port, recording, description, rig),
                                     name=f"record {instance}/{port}") for instance, port, description in described]
        if session:
            tasks.append(asyncio.create_task(_follow_session(client, recording, session), name=f"record {session}"))
        started = time.monotonic()
        ended = "stopped"
        try:
            ended = await _until_the_end(recording, tasks, stop, duration, started, progress, progress_period)
        finally:
            for task in tasks:
                task.cancel()
            results = await asyncio.gather(*tasks, return_exceptions=True)
            with contextlib.suppress(WriteFailed):  # said below, from the writer's failure
                await asyncio.shield(recording.close(ended))
        counts = recording.counts()
        if progress is not None:
            progress(counts, time.monotonic() - started)
        if recording.writer.failure is not None:
            failure = recording.writer.failure
            raise _failed(failure, path)
        for result in results:
            if isinstance(result, Exception) and not isinstance(result, asyncio.CancelledError):
                raise result
        return path, counts, ended


def _failed(failure: OSError, path: str) -> OSError:
    return WriteFailed(failure.errno, f"{failure.strerror or failure} (writing {path}; what it holds is readable)")


async def _until_the_end(recording: Recording, tasks: list[asyncio.Task[None]], stop: asyncio.Event,
                         duration: float | None, started: float,
                         progress: Callable[[RecordingCounts, float], None] | None, period: float) -> str:
    """Wait for *stop*, the duration, a write failure or a follower that failed; report progress meanwhile."""
    stopping = asyncio.ensure_future(stop.wait())
    failing = asyncio.ensure_future(recording.writer.failed.wait())
    try:
        while True:
            elapsed = time.monotonic() - started
            timeout = period if duration is None else max(0.0, min(period, duration - elapsed))
            # A port whose instance was unloaded has ended: the others go on (and are the ones waited for).
            running = [task for task in tasks if not task.done()]
            done, _ = await asyncio.wait([stopping, failing, *running], timeout=timeout,
                                         return_when=asyncio.FIRST_COMPLETED)
            if stopping in done:
                return "stopped"
            if failing in done:
                return "write failed"
            for task in running:
                if task in done and not task.cancelled() and task.exception() is not None:
                    return f"failed: {task.get_name()}: {task.exception()}"
            if duration is not None and time.monotonic() - started >= duration:
                return "duration"
            if progress is not None:
                progress(recording.counts(), time.monotonic() - started)
            if all(task.done() for task in tasks):
                return "every port ended (unloaded)"
    finally:
        stopping.cancel()
        failing.cancel()
