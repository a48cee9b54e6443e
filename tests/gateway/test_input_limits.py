"""Input that reaches the limits of decoding gets a documented 4xx, never a 500.

Each row is a request a fuzzer turned into an HTTP 500 (``Exceeds the limit``,
``OverflowError``, ``UnicodeEncodeError``, ``RecursionError``, ``int('²')``...).
"""

from __future__ import annotations

import logging
import re

import aiohttp
import pytest

from aiogenomix.gateway import GatewayConfig, serve
from tests.conftest import TEST_TIME_SCALE
from tests.gateway._raw_http import exchange_once

GOTO = "/module/demo/send/GotoPosition"
COUNT = "/module/countserver/send/CountFrom"

# (what, path, query, status, "ex", a word the message must hold)
LIMITS = [
    ("an integer of 5000 digits", GOTO, {"input": '{"posRef":' + "1" * 5000 + "}"}, 400,
     "::genom::serialization", "digits"),
    ("an integer of 4000 digits for a double", GOTO, {"input": '{"posRef":' + "1" * 4000 + "}"}, 400,
     "::genom::serialization", "too large for a double"),
    ("an integer of 4000 digits for a short", COUNT, {"input": '{"initial_value":' + "1" * 4000 + "}"}, 400,
     "::genom::serialization", "out of range for short"),
    ("a lone surrogate in a string parameter", "/module/demo/send/connect_port",
     {"input": '{"local":"\\ud800","remote":"demo/Mobile"}'}, 400, "::genom::serialization", "surrogate"),
    ("a lone surrogate as a parameter name", GOTO, {"input": '{"\\udfff":1}'}, 400, "::genom::serialization",
     "surrogate"),
    # Deep enough for every parser's recursion limit (Python 3.13's C scanner takes 5000), within the URL limit.
    ("JSON nested 10000 deep", GOTO, {"input": "[" * 10000 + "]" * 10000}, 400, "::genom::serialization",
     "nested"),
    # Python 3.13 parses objects this deep (deeper ones exceed the URL limit): then the member is unknown.
    ("JSON nested 2700 deep", GOTO, {"input": '{"a":' * 2700 + "1" + "}" * 2700}, 400, "::genom::serialization",
     "nested|unknown parameter"),
    ("wait timeout NaN", "/module/demo/wait/0", {"timeout": "nan"}, 400, "::genom::serialization", "timeout"),
    ("wait timeout -1", "/module/demo/wait/0", {"timeout": "-1"}, 400, "::genom::serialization", "timeout"),
    ("wait timeout -inf", "/module/demo/wait/0", {"timeout": "-inf"}, 400, "::genom::serialization", "timeout"),
    ("an unknown load option", "/load/demo", {"argv": "-i b --no-such-option"}, 400, "::genomix::bad_load",
     "--no-such-option"),
    ("a stray load argument", "/load/demo", {"argv": "extra"}, 400, "::genomix::bad_load", "extra"),
    ("-i twice", "/load/demo", {"argv": "-i b -i c"}, 400, "::genomix::bad_load", "twice"),
    ("name= on a simple port", "/module/demo/read/Mobile", {"name": "x"}, 400, "::genom::serialization",
     "multiple"),
    ("name= on a watch of a simple port", "/module/demo/watch/Mobile", {"name": ""}, 400,
     "::genom::serialization", "multiple"),
] + [
    (f"request id {shown} on {verb}", f"/module/demo/{verb}/{rqst}", {}, 404, "::genomix::no_such_request",
     "malformed")
    for verb in ("status", "wait", "abort", "clean")
    for shown, rqst in (("²", "²"), ("demo::١", "demo::١"), ("of 5000 digits", "9" * 5000))
]


async def test_inputs_at_the_limits_get_documented_errors(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    await http.get("/load/countserver")
    async with http.get(GOTO, params={"input": '{"posRef":0.5}'}) as reply:  # demo::0, running meanwhile
        assert (await reply.json())["status"] == "sent"
    for what, path, query, status, ex, word in LIMITS:
        async with http.get(path, params=query) as reply:
            body = await reply.json()
            assert (reply.status, body["ex"]) == (status, ex), (what, body)
            assert re.search(word, body["message"]) and len(body["message"]) < 400, (what, body["message"])
    async with http.get("/module/demo/wait/0") as reply:  # the gateway and the activity carried on
        assert (await reply.json()) == {"id": "demo::0", "status": "done", "output": {}}
    async with http.get("/") as reply:
        assert (await reply.json())["loaded"] == {"demo": "demo", "countserver": "countserver"}


async def test_large_numbers_in_range_still_decode(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    # A 300-digit integer is a valid (huge) double: refused by the component's own check, not the decoder.
    async with http.get(GOTO, params={"input": '{"posRef":' + "1" * 300 + "}"}) as reply:
        body = await reply.json()
    assert reply.status < 500 and body.get("ex") != "::genom::serialization"


async def test_a_non_utf8_authorization_header_is_refused_quietly(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, token="s3cret")
    async with serve(config) as url:
        named = f"GET /version HTTP/1.1\r\nHost: {url.removeprefix('http://')}\r\n".encode()
        token = b"Authorization: Bearer \xff\xfe\xc3\r\n"
        _, head, body = await exchange_once(url, named + token + b"Connection: close\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 401")
    assert b'"ex":"::genomix::unauthorized"' in body
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []


async def test_instances_have_a_cap() -> None:
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, max_instances=2)
    async with serve(config) as url, aiohttp.ClientSession(base_url=url) as http:
        for argv in ("", "-i demo2"):
            async with http.get("/load/demo", params={"argv": argv}) as reply:
                assert reply.status == 200
        async with http.get("/load/demo", params={"argv": "-i demo3"}) as reply:
            body = await reply.json()
            assert (reply.status, body["ex"]) == (429, "::genomix::too_many_instances")
            assert "unload" in body["message"]
        async with http.get("/load/demo") as reply:  # a running instance is returned, not counted again
            assert reply.status == 200
        await http.get("/unload/demo2")
        async with http.get("/load/demo", params={"argv": "-i demo3"}) as reply:
            assert reply.status == 200
