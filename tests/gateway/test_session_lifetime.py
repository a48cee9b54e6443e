"""Sessions are bounded: checked names, an idle expiry for unlistened ones, a cap on their number."""

from __future__ import annotations

import functools
from collections.abc import AsyncIterator

import aiohttp
import pytest

from aiogenomix.gateway import GatewayConfig, _app, serve
from aiogenomix.gateway._sessions import SessionStore
from tests.conftest import TEST_TIME_SCALE, RawEventStream

GOTO = "/module/demo/send/GotoPosition"


class FakeClock:
    """The sessions' clock, moved by the test instead of waited for."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> FakeClock:
    clock = FakeClock()
    monkeypatch.setattr(_app, "SessionStore", functools.partial(SessionStore, clock=clock))
    return clock


@pytest.fixture
def gateway_config() -> GatewayConfig:
    return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, session_idle=60, max_sessions=3)


@pytest.fixture
async def gateway(clock: FakeClock, gateway_config: GatewayConfig) -> AsyncIterator[str]:
    async with serve(gateway_config) as url:
        yield url


async def _session_count(http: aiohttp.ClientSession) -> int:
    async with http.get("/") as reply:
        return int((await reply.json())["sessions"])


async def test_unlistened_sessions_expire_and_their_requests_run_on(gateway: str, http: aiohttp.ClientSession,
                                                                    clock: FakeClock) -> None:
    await http.get("/load/demo")
    async with http.get(GOTO, params={"s": "walker", "input": '{"posRef":0.5}'}) as reply:
        assert (await reply.json()) == {"id": "demo::0", "status": "sent"}
    await http.get("/session/start", params={"s": "kept"})
    stream = await RawEventStream.open(gateway, "listened")
    try:
        assert await _session_count(http) == 3
        clock.now += 59
        assert await _session_count(http) == 3
        clock.now += 2  # 61 s without a listener or a use
        assert await _session_count(http) == 1  # only the listened one is left
        async with http.get("/session/stop", params={"s": "walker"}) as reply:
            assert (reply.status, (await reply.json())["ex"]) == (404, "::genomix::no_such_session")
        # The request of the expired session ran on, and its status can still be read.
        async with http.get("/module/demo/wait/demo::0") as reply:
            assert await reply.json() == {"id": "demo::0", "status": "done", "output": {}}
        # The listened session is intact: its listener still gets its events.
        async with http.get("/module/demo/send/GetSpeed", params={"s": "listened"}) as reply:
            assert (await reply.json())["status"] == "done"
        assert (await stream.next_event())[0] == "request"
    finally:
        stream.close()


async def test_using_a_session_keeps_it(gateway: str, http: aiohttp.ClientSession, clock: FakeClock) -> None:
    await http.get("/load/demo")
    await http.get("/session/start", params={"s": "busy"})
    for _ in range(3):
        clock.now += 50
        async with http.get("/module/demo/send/GetSpeed", params={"s": "busy"}) as reply:
            assert reply.status == 200
    assert await _session_count(http) == 1
    clock.now += 60
    assert await _session_count(http) == 0


async def test_sessions_have_a_cap(gateway: str, http: aiohttp.ClientSession, clock: FakeClock) -> None:
    await http.get("/load/demo")
    for name in ("a", "b", "c"):
        async with http.get("/session/start", params={"s": name}) as reply:
            assert reply.status == 200
    async with http.get("/session/start", params={"s": "a"}) as reply:  # an existing one is reused
        assert reply.status == 200
    for path, query in (("/session/start", {"s": "d"}), ("/session/start", {}), ("/session/listen", {"s": "d"}),
                        (GOTO, {"s": "d", "input": "0.5"})):
        async with http.get(path, params=query) as reply:
            body = await reply.json()
            assert (reply.status, body["ex"]) == (429, "::genomix::too_many_sessions"), path
            assert "/session/stop" in body["message"]
    async with http.get("/module/demo/status/0") as reply:  # the refused send started nothing
        assert reply.status == 404
    await http.get("/session/stop", params={"s": "a"})
    async with http.get("/session/start", params={"s": "d"}) as reply:
        assert reply.status == 200
    clock.now += 60  # idle sessions make room by expiring
    async with http.get("/session/start", params={"s": "e"}) as reply:
        assert reply.status == 200


BAD_NAMES = ["\x00", "a\r\nevent: quit", "tab\there", "\u2028", "\x7f", "\x92", "x" * 129, "é" * 129]


@pytest.mark.parametrize("name", BAD_NAMES, ids=["nul", "crlf", "tab", "line-separator", "del", "c1", "129-ascii",
                                                 "129-accented"])
async def test_session_names_are_checked(http: aiohttp.ClientSession, name: str) -> None:
    await http.get("/load/demo")
    for path, query in (("/session/start", {}), ("/session/listen", {}), ("/session/stop", {}),
                        ("/module/demo/send/GetSpeed", {})):
        async with http.get(path, params={"s": name, **query}) as reply:
            body = await reply.json()
            assert (reply.status, body["ex"]) == (400, "::genom::serialization"), path
            assert "session name" in body["message"]
    assert await _session_count(http) == 0


async def test_printable_names_up_to_128_characters_are_fine(http: aiohttp.ClientSession) -> None:
    for name in ("tête-à-tête, with spaces", "x" * 128, "é" * 128):  # three: the cap of this module
        async with http.get("/session/start", params={"s": name}) as reply:
            assert (reply.status, await reply.text()) == (200, name)
