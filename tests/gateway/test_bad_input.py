"""Bad input gets the documented genomix-style reply, and disturbs no other session.

Two tables of docs/protocol.md: protocol faults (HTTP errors, no request) and
refusals by the component (HTTP 200, a request that ends in ``error``).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import aiohttp
import pytest

from tests.conftest import RawEventStream

GOTO = "/module/demo/send/GotoPosition"

# (what, path, query, expected status, expected "ex") — the HTTP error table of docs/protocol.md.
BAD_INPUT = [
    ("malformed JSON", GOTO, {"input": '{"posRef":'}, 400, "::genom::serialization"),
    ("unknown member", GOTO, {"input": '{"pos":1}'}, 400, "::genom::serialization"),
    ("a member given twice", GOTO, {"input": '{"posRef":0.3,"posRef":0.6}'}, 400, "::genom::serialization"),
    ("string for a double", GOTO, {"input": '{"posRef":"x"}'}, 400, "::genom::serialization"),
    ("1.5 for a short", "/module/countserver/send/CountFrom", {"input": '{"initial_value":1.5}'}, 400,
     "::genom::serialization"),
    ("short out of range", "/module/countserver/send/CountFrom", {"input": '{"initial_value":70000}'}, 400,
     "::genom::serialization"),
    ("unknown enum", "/module/demo/send/SetSpeed", {"input": '{"speedRef":"VERY_FAST"}'}, 400,
     "::genom::serialization"),
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

# (what, path, input, expected exception object) — the refusal table of docs/protocol.md: HTTP 200,
# the request ends in error with the component's exception, and its session gets the request event.
REFUSALS = [
    ("off the track", GOTO, '{"posRef":2}', {"ex": "::demo::TOO_FAR_AWAY", "detail": {"overshoot": 1.0}}),
    ("null (NaN) position", GOTO, '{"posRef":null}',
     {"ex": "::demo::INVALID_VALUE", "detail": {"parameter": "posRef", "value": "nan"}}),
    ("infinite position", GOTO, '{"posRef":Infinity}',
     {"ex": "::demo::INVALID_VALUE", "detail": {"parameter": "posRef", "value": "inf"}}),
    ("infinite distance", "/module/demo/send/MoveDistance", '{"distRef":-Infinity}',
     {"ex": "::demo::INVALID_VALUE", "detail": {"parameter": "distRef", "value": "-inf"}}),
    ("watched position that is not a number", "/module/demo/send/Monitor", '{"monitor":NaN}',
     {"ex": "::demo::INVALID_VALUE", "detail": {"parameter": "monitor", "value": "nan"}}),
    ("CountFrom beyond the limit", "/module/countserver/send/CountFrom", '{"initial_value":5000}',
     {"ex": "::countserver::INVALID_INITIAL_VALUE"}),
    ("kemar move before Homing", "/module/kemar/send/MoveAbsolutePosition", '{"target":10}',
     {"ex": "::kemar::NOT_HOMED", "detail": {"message": "the head is not homed: call Homing first"}}),
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


async def test_refusals_end_their_request_in_error(gateway: str, http: aiohttp.ClientSession) -> None:
    for name in ("demo", "countserver", "kemar"):
        await http.get(f"/load/{name}")
    # A long activity of another session runs meanwhile; a refused request interrupts nothing.
    async with http.get(GOTO, params={"s": "busy", "input": '{"posRef":0.5}'}) as reply:
        assert await reply.json() == {"id": "demo::0", "status": "sent"}
    stream = await RawEventStream.open(gateway, "user")
    try:
        for what, path, given, exception in REFUSALS:
            async with http.get(path, params={"s": "user", "input": given}) as reply:
                assert reply.status == 200, what
                body = await reply.json()
                assert int(reply.headers["Content-Length"]) == len(await reply.read()), what
            # A request id is used, and the status says what the component refused.
            assert body == {"id": body["id"], "status": "error", "exception": exception}, what
            assert body["id"].startswith(path.split("/")[2] + "::"), what
            # The session's listen stream shows it, like any other end of a request.
            name, data = await stream.next_event()
            assert (name, json.loads(data or "")) == ("request", body), what
            async with http.get(f"/module/{path.split('/')[2]}/status/{body['id']}") as reply:
                assert await reply.json() == body, what
        async with http.get("/module/demo/status/demo::0") as reply:
            assert (await reply.json())["status"] == "sent"
    finally:
        stream.close()


async def test_validate_refusal_carries_the_detail(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    async with http.get(GOTO, params={"input": '{"posRef":-1.25}'}) as reply:
        body = await reply.json()
    assert reply.status == 200
    assert body["status"] == "error" and body["exception"]["ex"] == "::demo::TOO_FAR_AWAY"
    assert body["exception"]["detail"] == {"overshoot": pytest.approx(0.25)}


@pytest.mark.parametrize("body", [
    '{"posRef":0.3,"posRef":0.6}',                     # issue 29: it moved demo to 0.6
    '{"posRef":0.3, "posRef" : NaN}',                  # genom3's lenient JSON too
    '{"posRef":0.6,"note":"a: colon","posRef":0.3}',   # a colon in a string does not hide it
])
async def test_a_member_given_twice_is_refused_by_get_and_post_alike(http: aiohttp.ClientSession, body: str) -> None:
    await http.get("/load/demo")
    for reply_of in (lambda: http.get(GOTO, params={"input": body}),
                     lambda: http.post(GOTO, data=body, headers={"Content-Type": "application/json"})):
        async with reply_of() as reply:
            assert reply.status == 400
            error = await reply.json()
        assert error["ex"] == "::genom::serialization" and "'posRef' twice" in error["message"], error
    async with http.get("/module/demo/read/Mobile") as reply:
        assert (await reply.json())["Mobile"]["position"] == 0.0  # demo never moved
    async with http.get("/module/demo/status/demo::0") as reply:
        assert reply.status == 404  # no request was made
    async with http.get("/module/demo/send/GotoPosition", params={"input": '{"posRef":0.2}'}) as reply:
        assert (await reply.json())["status"] in ("sent", "done")  # once, it is taken


def test_colons_in_strings_and_lists_of_objects_are_no_member_given_twice() -> None:
    from aiogenomix.gateway._input import parse_input

    text = '{"path":"C:/data:1","items":[{"k":1},{"k":2}],"grid":[[{"k":3}]],"n":[1,2]}'
    assert parse_input(text) == {"path": "C:/data:1", "items": [{"k": 1}, {"k": 2}], "grid": [[{"k": 3}]],
                                 "n": [1, 2]}


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


def test_the_tables_of_the_protocol_doc_are_the_tested_ones() -> None:
    doc = (Path(__file__).parents[2] / "docs" / "protocol.md").read_text()
    errors = doc[doc.index("| Bad input | Status | `ex` |"):doc.index("### Refused requests")]
    documented = set(re.findall(r"\| (\d{3}) \| `([^`]+)`", errors))
    assert {(str(status), ex) for *_, status, ex in BAD_INPUT} <= documented
    refusals = doc[doc.index("### Refused requests"):].split("\n## ", 1)[0]
    assert all(exception["ex"] in refusals for *_, exception in REFUSALS)
    assert "refused by the service's `validate`" not in errors  # no longer an HTTP error
