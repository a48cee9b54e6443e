"""Bad input gets the documented genomix-style error, and disturbs no other session."""

from __future__ import annotations

import json

import aiohttp
import pytest

from tests.conftest import RawEventStream

GOTO = "/module/demo/send/GotoPosition"

# (what, path, query, expected status, expected "ex") — the table of docs/protocol.md.
BAD_INPUT = [
    ("malformed JSON", GOTO, {"input": '{"posRef":'}, 400, "::genom::serialization"),
    ("unknown member", GOTO, {"input": '{"pos":1}'}, 400, "::genom::serialization"),
    ("string for a double", GOTO, {"input": '{"posRef":"x"}'}, 400, "::genom::serialization"),
    ("1.5 for a short", "/module/countserver/send/CountFrom", {"input": '{"initial_value":1.5}'}, 400,
     "::genom::serialization"),
    ("short out of range", "/module/countserver/send/CountFrom", {"input": '{"initial_value":70000}'}, 400,
     "::genom::serialization"),
    ("unknown enum", "/module/demo/send/SetSpeed", {"input": '{"speedRef":"VERY_FAST"}'}, 400,
     "::genom::serialization"),
    ("refused by validate", GOTO, {"input": '{"posRef":2}'}, 400, "::demo::TOO_FAR_AWAY"),
    ("null (NaN) position", GOTO, {"input": '{"posRef":null}'}, 400, "::demo::TOO_FAR_AWAY"),
    ("unknown module", "/module/nosuch/send/GotoPosition", {}, 404, "::genomix::no_such_module"),
    ("unknown service", "/module/demo/send/Fly", {}, 404, "::genom::no_such_service"),
    ("unknown port", "/module/demo/read/Nowhere", {}, 404, "::genom::no_such_outport"),
    ("unknown request", "/module/demo/status/demo::99", {}, 404, "::genomix::no_such_request"),
    ("malformed request id", "/module/demo/clean/abc", {}, 404, "::genomix::no_such_request"),
    ("another instance's request id", "/module/demo/status/countserver::0", {}, 404,
     "::genomix::no_such_request"),
    ("unknown session", "/session/stop", {"s": "nobody"}, 404, "::genomix::no_such_session"),
    ("clean of a running request", "/module/demo/clean/demo::0", {}, 409, "::genomix::request_running"),
    ("load of a path", "/load/%2Fopt%2Fgenom%2Fplugins%2Fdemo.so", {}, 403, "::genomix::forbidden"),
    ("load of an unknown component", "/load/nosuch", {}, 404, "::genomix::no_such_module"),
    ("-i without a name", "/load/demo", {"argv": "-i"}, 400, "::genomix::bad_load"),
    ("bad wait timeout", "/module/demo/wait/demo::0", {"timeout": "soon"}, 400, "::genom::serialization"),
]


async def test_bad_input_table(gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    await http.get("/load/countserver")
    # Session "busy" runs a long activity while session "other" sends every kind of bad input.
    stream = await RawEventStream.open(gateway, "busy")
    try:
        async with http.get(GOTO, params={"s": "busy", "input": '{"posRef":1}'}) as reply:
            assert await reply.json() == {"id": "demo::0", "status": "sent"}
        assert await stream.next_event() == ("request", '{"id":"demo::0","status":"sent"}')

        for what, path, query, status, ex in BAD_INPUT:
            async with http.get(path, params={"s": "other", **query}) as reply:
                body = await reply.json()
                assert (reply.status, body["ex"]) == (status, ex), what
                assert body["message"], what
                assert int(reply.headers["Content-Length"]) == len(await reply.read()), what

        # The running activity was not disturbed: it ends normally, at its target.
        name, data = await stream.next_event()
        assert (name, json.loads(data or "")) == ("request", {"id": "demo::0", "status": "done", "output": {}})
        async with http.get("/module/demo/read/Mobile") as reply:
            assert await reply.json() == {"Mobile": {"position": 1.0, "speed": 0.0}}
    finally:
        stream.close()


async def test_validate_refusal_carries_the_detail(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    async with http.get(GOTO, params={"input": '{"posRef":-1.25}'}) as reply:
        body = await reply.json()
    assert reply.status == 400
    assert body["ex"] == "::demo::TOO_FAR_AWAY"
    assert body["detail"] == {"overshoot": pytest.approx(0.25)}


async def test_genom_leniency_on_input(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    # Short enum names, a bare value for a one-parameter service, NaN-tolerant parsing.
    async with http.get("/module/demo/send/SetSpeed", params={"input": '"FAST"'}) as reply:
        assert (await reply.json())["status"] == "done"
    async with http.get("/module/demo/send/GetSpeed") as reply:
        assert (await reply.json())["output"] == {"speedRef": "::demo::FAST"}


async def test_too_many_activities_is_429(gateway_config, http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    from aiogenomix.components.demo import Demo

    limit = Demo.max_activities
    for _ in range(limit):
        async with http.get("/module/demo/send/Monitor", params={"input": '{"monitor":0.5}'}) as reply:
            assert (await reply.json())["status"] == "sent"
    async with http.get("/module/demo/send/Monitor", params={"input": '{"monitor":0.5}'}) as reply:
        assert reply.status == 429
        assert (await reply.json())["ex"] == "::genom::too_many_activities"
