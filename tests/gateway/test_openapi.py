"""``/openapi.json`` (issue 13): a valid OpenAPI 3.1 document, and Schemathesis finds no server error with it."""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

import aiohttp
import pytest
from hypothesis import HealthCheck, given, settings

from aiogenomix.gateway import GatewayConfig, serve_in_thread

from ..conftest import TEST_TIME_SCALE

#: Examples per operation (the fuzzing of test_fuzz.py covers every endpoint at length; this checks the document).
EXAMPLES = int(os.environ.get("AIOGENOMIX_OPENAPI_EXAMPLES", "10"))
#: Not fuzzed: streams that never end, waits that may last an hour, what unloads the modules under test.
SKIPPED = ("/session/listen", "/watch/", "/wait/", "/unload/", "/send/kill", "/session/stop")


async def test_the_document_is_valid_openapi_with_one_path_per_service(http: aiohttp.ClientSession) -> None:
    from openapi_spec_validator import validate

    for name in ("demo", "countserver", "kemar"):
        async with http.get(f"/load/{name}") as loaded:
            assert loaded.status == 200
    async with http.get("/openapi.json") as reply:
        assert reply.status == 200
        document = await reply.json()
    validate(document)
    assert document["openapi"] == "3.1.0"
    goto = document["paths"]["/module/demo/send/GotoPosition"]["get"]
    (input_param,) = [p for p in goto["parameters"] if p.get("name") == "input"]
    schema = input_param["content"]["application/json"]["schema"]
    assert schema["properties"]["posRef"] == {"type": "number", "description": "Goto position in m", "default": 0.0}
    speed = document["paths"]["/module/demo/send/SetSpeed"]["get"]["parameters"][0]["content"]
    assert "::demo::FAST" in speed["application/json"]["schema"]["properties"]["speedRef"]["enum"]
    count_from = document["paths"]["/module/countserver/send/CountFrom"]["get"]["parameters"][0]["content"]
    assert count_from["application/json"]["schema"]["properties"]["initial_value"]["maximum"] == 32767
    error = goto["responses"]["200"]["content"]["application/json"]["schema"]["oneOf"][2]
    raised = [e.get("properties", {}).get("ex", {}).get("const") for e in error["properties"]["exception"]["anyOf"]]
    assert "::demo::TOO_FAR_AWAY" in raised and "400" in goto["responses"]
    assert "/module/kemar/send/MoveAbsolutePosition" in document["paths"]


@pytest.fixture
def threaded_gateway() -> Iterator[str]:
    config = GatewayConfig(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, preload=["demo", "countserver"])
    with serve_in_thread(config) as url:
        yield url


def test_schemathesis_finds_no_server_error(threaded_gateway: str) -> None:
    import schemathesis

    schema = schemathesis.openapi.from_url(f"{threaded_gateway}/openapi.json")
    operations = [r.ok() for r in schema.get_all_operations()]
    operations = [op for op in operations if not any(s in op.path for s in SKIPPED)]
    assert any(op.path == "/module/demo/send/GotoPosition" for op in operations)
    failures: list[str] = []
    calls = 0

    for operation in operations:

        @given(case=operation.as_strategy())
        @settings(max_examples=EXAMPLES, deadline=None, database=None,
                  suppress_health_check=list(HealthCheck))
        def call(case: Any) -> None:
            nonlocal calls
            calls += 1
            response = case.call(base_url=threaded_gateway, timeout=30)
            if response.status_code >= 500:
                failures.append(f"{response.status_code} {case.as_curl_command()}: {response.text[:200]}")

        call()
    assert failures == []
    assert calls >= 2 * len(operations), calls
