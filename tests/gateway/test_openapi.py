"""``/openapi.json`` (issue 13): a valid OpenAPI 3.1 document, and Schemathesis finds no server error with it."""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

import aiohttp
import pytest
from hypothesis import HealthCheck, given, settings

from aiogenomix.gateway import GatewayConfig, serve, serve_in_thread

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
    schemas = document["components"]["schemas"]
    goto = document["paths"]["/module/demo/send/GotoPosition"]
    # The typed form: a JSON body whose model is named for generators.
    body = goto["post"]["requestBody"]["content"]["application/json"]["schema"]
    assert body == {"$ref": "#/components/schemas/demo_GotoPosition_Input"}
    model = schemas["demo_GotoPosition_Input"]
    assert model["properties"]["posRef"] == {"type": ["number", "null"], "description": "Goto position in m",
                                             "x-unit": "m", "default": 0.0}
    # genomix's form keeps input as JSON text of the same model.
    (input_param,) = [p for p in goto["get"]["parameters"] if p.get("name") == "input"]
    assert input_param["schema"]["type"] == "string"
    assert input_param["schema"]["contentSchema"] == body
    assert goto["post"]["operationId"] == "demo_GotoPosition"
    assert goto["get"]["operationId"] == "demo_GotoPosition_query"
    speed = schemas["demo_SetSpeed_Input"]["properties"]["speedRef"]
    assert "::demo::FAST" in speed["enum"] and "FAST" in speed["enum"]
    assert schemas["countserver_CountFrom_Input"]["properties"]["initial_value"]["maximum"] == 32767
    assert "::demo::TOO_FAR_AWAY" in goto["post"]["description"] and "400" in goto["post"]["responses"]
    # A send's id leads to its status, wait, abort and clean.
    links = goto["post"]["responses"]["200"]["links"]
    assert {link["operationId"] for link in links.values()} == {"getStatus", "waitRequest", "abortRequest",
                                                                 "cleanRequest"}
    assert links["wait"]["parameters"] == {"module": "demo", "rqst": "$response.body#/id"}
    # Ports read as typed objects.
    mobile = document["paths"]["/module/demo/read/Mobile"]["get"]
    assert mobile["responses"]["200"]["content"]["application/json"]["schema"] == {
        "$ref": "#/components/schemas/demo_read_Mobile_Reply"}
    assert schemas["demo_read_Mobile_Reply"]["properties"]["Mobile"] == {"$ref": "#/components/schemas/demo_state"}
    assert schemas["demo_state"]["required"] == ["position", "speed"]
    assert "/module/kemar/send/MoveAbsolutePosition" in document["paths"]
    operations = [op for path in document["paths"].values() for op in path.values()]
    ids = [op["operationId"] for op in operations]
    assert len(ids) == len(set(ids)) == len(operations)  # every operation has an id of its own
    assert document["security"] == [{}]  # no token on this gateway
    wait_timeout = document["paths"]["/module/{module}/wait/{rqst}"]["get"]["parameters"][2]["schema"]
    assert wait_timeout["maximum"] == 3600


async def test_with_a_token_every_operation_but_the_consoles_needs_it() -> None:
    config = GatewayConfig.of(port=0, audio_socket_port=0, token="s3cret")
    async with serve(config) as url, aiohttp.ClientSession() as http:
        async with http.get(f"{url}/openapi.json", headers={"Authorization": "Bearer s3cret"}) as reply:
            document = await reply.json()
    assert document["security"] == [{"token": []}]
    assert document["components"]["securitySchemes"]["token"] == {
        "type": "http", "scheme": "bearer", "description": "The gateway's --token"}
    open_paths = sorted(path for path, item in document["paths"].items() if item["get"].get("security") == [])
    assert open_paths == ["/console", "/console/auth", "/console/login", "/docs", "/openapi.json"]


@pytest.fixture
def threaded_gateway() -> Iterator[str]:
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, preload=["demo", "countserver"])
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
