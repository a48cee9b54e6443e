"""Viewers of the live view (issue 29, item 2): the gateway's memory with viewers that never read, and the count.

The gateway's command line with ``--foxglove`` and its default budgets (``--max-viewers`` 8,
``--max-viewer-bytes`` 32 MiB), a world of 512x512 cameras at 5 Hz (the issue's) and a sound
capture.  For one and for four viewers that subscribe to every camera (three of them) and never
read again (a 4 KiB receive buffer; their client stops reading after one message), beside one
viewer that reads the head and a camera: the gateway's resident memory is sampled every 50 ms for
``seconds``, and the figure is its peak above what it held before the viewers came, against the
budget (``--max-viewer-bytes`` a viewer).  Then the same with viewers that also subscribe to the
audio (which never replaces a chunk): each passes its budget and is dropped.  Last, 500 viewers try
to connect at once: how many are admitted.  Before issue 29 one such viewer cost 144 MiB, four
553 MiB, and 500 were admitted.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import socket
from collections.abc import AsyncIterator
from typing import TYPE_CHECKING, Any, cast

import aiohttp

from ._common import Result, free_port, rss_bytes, verdict
from .budgets import _gateway, _Peak, _send

if TYPE_CHECKING:
    from websockets.typing import Subprotocol

MIB = 2**20
#: The gateway's default budget of one viewer (``--max-viewer-bytes``) and count (``--max-viewers``).
VIEWER_BYTES = 32 * MIB
MAX_VIEWERS = 8
BEFORE = {1: 144, 4: 553}  # MiB, measured in issue 29 with the Foxglove SDK's server
SUBPROTOCOL = cast("list[Subprotocol]", ["foxglove.sdk.v1"])


@contextlib.asynccontextmanager
async def _never_reading(port: int, wanted: Any) -> AsyncIterator[Any]:
    """A viewer that subscribes to the channels *wanted* picks (from the advertisement) and never reads again."""
    import websockets

    raw = socket.socket()
    raw.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    raw.setblocking(False)
    await asyncio.get_running_loop().sock_connect(raw, ("127.0.0.1", port))
    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOL,
                                  sock=raw, max_queue=1, max_size=None, close_timeout=0.1) as viewer:
        channels = await _channels(viewer)
        await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": n, "channelId": c["id"]} for n, c in enumerate(channels) if wanted(c)]}))
        yield viewer


async def _channels(viewer: Any) -> list[dict[str, Any]]:
    """The advertised channels (the first advertisement holds every loaded instance's)."""
    while True:
        message = json.loads(await asyncio.wait_for(viewer.recv(), 60))
        if message["op"] == "advertise":
            return list(message["channels"])


def _camera(channel: dict[str, Any]) -> bool:
    return bool(channel["schemaName"] == "foxglove.RawImage")


def _camera_or_audio(channel: dict[str, Any]) -> bool:
    return channel["schemaName"] in ("foxglove.RawImage", "foxglove.RawAudio")


async def _reader(port: int, got: list[int]) -> None:
    """A viewer that reads the head and a camera, counting what it gets."""
    import websockets

    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOL,
                                  max_size=None) as viewer:
        channels = {c["topic"]: c for c in await _channels(viewer)}
        await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": channels["/kemar/currentState"]["id"]},
            {"id": 2, "channelId": channels["/world/kemar_camera_left"]["id"]}]}))
        async for frame in viewer:
            if isinstance(frame, bytes):
                got[0] += 1


async def _round(port: int, pid: int, viewers: int, wanted: Any, seconds: float) -> Result:
    await asyncio.sleep(2.0)  # the world's first frames, the capture's first chunks: settled
    before = rss_bytes(pid)
    got = [0]
    reader = asyncio.create_task(_reader(port, got))
    async with contextlib.AsyncExitStack() as stack, _Peak(pid) as peak:
        for _ in range(viewers):
            await stack.enter_async_context(_never_reading(port, wanted))
        await asyncio.sleep(seconds)  # the span sampled: the measure is of time
        read_during = got[0]
    reader.cancel()
    with contextlib.suppress(asyncio.CancelledError, Exception):
        await reader
    grew = (peak.peak - before) / MIB
    budget = viewers * VIEWER_BYTES / MIB
    return {"viewers": viewers, "before_mib": before / MIB, "peak_mib": peak.peak / MIB, "grew_mib": grew,
            "budget_mib": budget, "reader_messages": read_during, "before_issue_mib": BEFORE.get(viewers),
            "verdict": verdict(grew, budget) if read_during > 0 else "MISSED"}


async def _crowd(port: int, tries: int) -> Result:
    """*tries* viewers connect at once: how many are admitted, and how the others are told."""
    import websockets

    async def one() -> int:
        try:
            viewer = await websockets.connect(f"ws://127.0.0.1:{port}",
                                              subprotocols=SUBPROTOCOL, open_timeout=60)
        except websockets.InvalidStatus as refused:
            return int(refused.response.status_code)
        except (TimeoutError, OSError):
            return 0
        opened.append(viewer)
        return 101

    opened: list[Any] = []
    statuses = await asyncio.gather(*(one() for _ in range(tries)))
    for viewer in opened:
        await viewer.close()
    return {"tries": tries, "admitted": statuses.count(101), "refused_429": statuses.count(429),
            "other": len(statuses) - statuses.count(101) - statuses.count(429), "max_viewers": MAX_VIEWERS,
            "verdict": verdict(statuses.count(101), MAX_VIEWERS)}


async def run(seconds: float = 20.0, crowd: int = 500) -> Result:
    """The rounds (see the module's description)."""
    rounds: dict[str, Any] = {}
    for name, viewers, wanted in (("cameras_1", 1, _camera), ("cameras_4", 4, _camera),
                                  ("cameras_and_audio_4", 4, _camera_or_audio)):
        view_port = free_port()
        async with _gateway("--foxglove", str(view_port), "--load", "world:-size 512x512 -rate 5",
                            "--load", "kemar", "--load", "kemarcapture") as (url, _, pid, _process):
            async with aiohttp.ClientSession(url) as http:
                await _send(http, "/module/kemarcapture/send/StartCapture", {"device": "sim", "Port_chunks": 200})
            rounds[name] = await _round(view_port, pid, viewers, wanted, seconds)
            if name == "cameras_and_audio_4":
                rounds["crowd"] = await _crowd(view_port, crowd)
    return rounds


def render(r: Result) -> str:
    """The section of docs/benchmarks.md."""
    rows = []
    for name, what in (("cameras_1", "1 viewer of the cameras"), ("cameras_4", "4 viewers of the cameras"),
                       ("cameras_and_audio_4", "4 viewers of the cameras and the audio (each dropped)")):
        x = r[name]
        before = f"{x['before_issue_mib']:,}" if x.get("before_issue_mib") else ""
        rows.append(f"| {what} | {x['before_mib']:.0f} | {x['peak_mib']:.0f} | {x['grew_mib']:.1f} | "
                    f"{x['budget_mib']:.0f} | {before} | {x['reader_messages']} | **{x['verdict']}** |")
    crowd = r["crowd"]
    return "\n".join([
        "## Viewers of the live view: viewers that never read, and the count", "",
        "The gateway's command line with `--foxglove` and its default budgets (`--max-viewers` 8, "
        "`--max-viewer-bytes` 32 MiB), a world of 512x512 cameras at 5 Hz (three cameras, 1 MiB a picture) and a "
        "sound capture. Viewers subscribe to every camera (and, in the last row, the audio) and never read again "
        "(a 4 KiB receive buffer), beside a viewer that reads the head and a camera. Memory is the gateway's "
        "resident set, sampled every 50 ms: its peak above what it held before the viewers came, against the "
        "budget (`--max-viewer-bytes` a viewer). A port's newer message replaces one a viewer has not taken: a "
        "never-reading viewer of the cameras holds a picture a camera; one that also listens to the audio passes "
        "its budget and is dropped.", "",
        "| run | before, MiB | peak, MiB | grew, MiB | budget, MiB | grew before issue 29, MiB | reader's messages "
        "meanwhile | verdict |",
        "|---|---|---|---|---|---|---|---|",
        *rows, "",
        f"**The count:** {crowd['tries']} viewers connect at once: {crowd['admitted']} admitted, "
        f"{crowd['refused_429']} refused 429 naming `--max-viewers`, {crowd['other']} otherwise. Target: at most "
        f"{crowd['max_viewers']} admitted: **{crowd['verdict']}** (before issue 29: all 500).", ""])
