"""Issue 29, item 3: a recording of a session ends with it, unless it was asked to outlive it.

Over HTTP.  A session ends when its client stops it (``/session/stop``), or when its client is
gone: nobody listens to it and nobody used it for ``--session-idle``, noticed on time whether or
not another client comes.  A recording sent in no session, or with ``outlive_session``, goes on.
The rig's clock stands still (``ManualClock``): what ends a recording here is an event, awaited.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import orjson
import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.components.recording import RecordingReader
from aiogenomix.gateway import GatewayConfig, _app, serve
from aiogenomix.gateway._sessions import SessionStore
from tests.conftest import RawEventStream

from tests.gateway.test_session_lifetime import FakeClock

#: Seconds a test waits for what happens at once (a bound, not a pace).
WITHIN = 30.0


@pytest.fixture
def session_clock(monkeypatch: pytest.MonkeyPatch) -> FakeClock:
    """The sessions' clock, moved by the test instead of waited for."""
    clock = FakeClock()
    monkeypatch.setattr(_app, "SessionStore", functools.partial(SessionStore, clock=clock))
    return clock


@contextlib.asynccontextmanager
async def gateway(tmp_path: Path, config: GatewayConfig) -> AsyncIterator[tuple[aiohttp.ClientSession, str]]:
    """A gateway on a clock that stands still, a capture and two recorders loaded; yields a client and its URL."""
    settings = HostSettings(can_timeout=10.0, audio_socket_port=0, record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=ManualClock(), settings=settings) as host, serve(config, host) as url, \
            aiohttp.ClientSession(base_url=url) as http:
        for name in ("capture", "recorder", "recorder:-i other"):
            module, _, argv = name.partition(":")
            async with http.get(f"/load/{module}", params={"argv": argv} if argv else {}) as loaded:
                assert loaded.status == 200, await loaded.text()
        yield http, url


@pytest.fixture
async def lab(tmp_path: Path, session_clock: FakeClock) -> AsyncIterator[tuple[aiohttp.ClientSession, str]]:
    async with gateway(tmp_path, GatewayConfig.of(port=0, session_idle=60)) as served:
        yield served


async def start(http: aiohttp.ClientSession, path: str, session: str | None, module: str = "recorder",
                **inputs: Any) -> str:
    params = {"input": orjson.dumps({"path": path, "ports": ["capture/Port"], **inputs}).decode()}
    if session is not None:
        params["s"] = session
    async with http.get(f"/module/{module}/send/Start", params=params) as reply:
        status = await reply.json()
    assert status["status"] == "sent", status
    return str(status["id"])


async def final(http: aiohttp.ClientSession, module: str, request_id: str) -> dict[str, Any]:
    """The request's status once it has ended (awaited: the gateway answers when it ends)."""
    async with http.get(f"/module/{module}/wait/{request_id}", params={"timeout": str(WITHIN)}) as reply:
        status: dict[str, Any] = await reply.json()
    assert status["status"] != "sent", f"{request_id} did not end within {WITHIN} s"
    return status


async def running(http: aiohttp.ClientSession, module: str, request_id: str) -> bool:
    async with http.get(f"/module/{module}/status/{request_id}") as reply:
        return (await reply.json())["status"] == "sent"  # type: ignore[no-any-return]


def ended_as_recorded(path: Path) -> str:
    with open(path, "rb") as stream, RecordingReader(stream) as reader:
        return reader.metadata()["aiogenomix.end"]["ended"]


async def test_stopping_the_session_stops_its_recording_and_no_other(
        lab: tuple[aiohttp.ClientSession, str], tmp_path: Path) -> None:
    http, _ = lab
    mine = await start(http, "mine.mcap", "lab")
    kept = await start(http, "kept.mcap", "lab", module="other", outlive_session=True)
    async with http.get("/session/stop", params={"s": "lab"}) as stopped:
        assert stopped.status == 200
    status = await final(http, "recorder", mine)
    assert status["status"] == "done" and status["output"]["status"]["ended"] == "session lab ended"
    assert ended_as_recorded(tmp_path / "mine.mcap") == "session lab ended"
    # Asked to outlive it: it runs until its Stop.
    assert await running(http, "other", kept)
    async with http.get("/module/other/send/Stop") as stopped:
        assert (await stopped.json())["status"] == "done"
    assert (await final(http, "other", kept))["output"]["status"]["ended"] == "stopped"


async def test_a_recording_stops_when_its_session_expires_unused(
        lab: tuple[aiohttp.ClientSession, str], session_clock: FakeClock) -> None:
    http, _ = lab
    recording = await start(http, "lab.mcap", "lab")
    nobodys = await start(http, "nobodys.mcap", None, module="other")
    session_clock.now += 59
    async with http.get("/") as reply:   # any client: the gateway looks at its sessions
        assert (await reply.json())["sessions"] == 1
    assert await running(http, "recorder", recording)
    session_clock.now += 2
    async with http.get("/") as reply:
        assert (await reply.json())["sessions"] == 0
    status = await final(http, "recorder", recording)
    assert status["status"] == "done" and status["output"]["status"]["ended"] == "session lab ended"
    # A recording sent in no session belongs to no client: only the budgets end it.
    assert await running(http, "other", nobodys)
    async with http.get("/module/other/send/Stop") as stopped:
        assert (await stopped.json())["status"] == "done"


async def test_a_recording_whose_client_went_away_stops_though_no_client_comes(tmp_path: Path) -> None:
    # The sessions' own clock: real seconds.  The gateway notices the listener gone (its next keep-alive),
    # then the session's idle time passes: nothing but the gateway's own look at its sessions ends it.
    async with gateway(tmp_path, GatewayConfig.of(port=0, session_idle=0.2, ping_interval=0.05)) as (http, url):
        listening = await RawEventStream.open(url, "left")
        recording = await start(http, "left.mcap", "left")
        assert await running(http, "recorder", recording)
        listening.close()
        async with asyncio.timeout(WITHIN):
            status = await final(http, "recorder", recording)
        assert status["output"]["status"]["ended"] == "session left ended"
