"""The genom3 standard services of a component of another package, as a client of the gateway sees them.

Every component has ``abort_activity``, ``connect_port``, ``connect_service`` and ``kill``,
declared once (``GenomServices``): ``/info`` documents them last, in genom3's order, with their
parameters and the exceptions they end in, and a component that redeclares one to say what its
own in port takes shows its own doc and still runs the standard service.
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Double, GenomServices, InPort, OutPort, idl_struct, redeclare,
)
from aiogenomix.gateway import GatewayConfig, serve

STANDARD = ["abort_activity", "connect_port", "connect_service", "kill"]
FEED_DOC = "Connect Feed to a spool's Rope (another_spool/Rope): the rope this spool takes up"


@idl_struct("spool::rope")
class RopeOut:
    """How much rope is out."""

    out: Double = 0.0


class Spool(Component, name="spool"):
    """A spool that takes up another spool's rope."""

    Rope = OutPort(RopeOut, doc="The rope out")
    Feed = InPort(RopeOut, doc="The rope it takes up")

    @redeclare(GenomServices.connect_port, doc=FEED_DOC)
    async def connect_port(self, **inputs: Any) -> None:
        await GenomServices.connect_port(self, **inputs)


class Plain(Component, name="plain"):
    """A component that declares nothing but a port."""

    Rope = OutPort(RopeOut, doc="The rope out")


@pytest.fixture
async def http() -> AsyncIterator[aiohttp.ClientSession]:
    async with ComponentHost(factories={"spool": Spool, "plain": Plain}) as host, \
            serve(GatewayConfig.of(port=0), host) as url, aiohttp.ClientSession(base_url=url) as session:
        yield session


async def _info(http: aiohttp.ClientSession, module: str) -> dict[str, Any]:
    async with http.get(f"/load/{module}") as reply:
        assert reply.status == 200
    async with http.get(f"/module/{module}/info") as reply:
        info: dict[str, Any] = await reply.json()
    return info


async def _send(http: aiohttp.ClientSession, module: str, service: str, inputs: dict[str, Any]) -> dict[str, Any]:
    async with http.get(f"/module/{module}/send/{service}", params={"input": json.dumps(inputs)}) as reply:
        sent: dict[str, Any] = await reply.json()
    async with http.get(f"/module/{module}/wait/{sent['id']}") as reply:
        ended: dict[str, Any] = await reply.json()
    return ended


async def test_info_documents_the_standard_services_last(http: aiohttp.ClientSession) -> None:
    services = {s["name"]: s for s in (await _info(http, "plain"))["services"]}
    assert list(services) == STANDARD  # nothing of its own: the standard ones alone, in genom3's order
    for service in services.values():
        assert service["doc"] and not service["doc"].startswith(" ")
    abort = services["abort_activity"]
    assert abort["kind"] == "function" and abort["throws"] == ["::genom::no_such_activity"]
    assert [(p["name"], p["dir"], p["type"]["name"]) for p in abort["parameters"]] == [
        ("activity", "in", "unsigned long")]
    connect = services["connect_port"]
    assert [(p["name"], p["type"]) for p in connect["parameters"]] == [
        ("local", {"name": "string<128>", "kind": "string", "bound": 128}),
        ("remote", {"name": "string<128>", "kind": "string", "bound": 128})]
    assert connect["throws"] == ["::genom::no_such_inport", "::genom::no_such_outport", "::genom::port_io",
                                 "::genom::remote_io"]
    assert services["connect_service"]["throws"] == ["::genom::no_such_service"]
    assert services["kill"]["kind"] == "activity" and services["kill"]["parameters"] == []
    assert "Stop the component" in services["kill"]["doc"]


async def test_a_redeclared_standard_service_shows_its_doc_and_runs(http: aiohttp.ClientSession) -> None:
    plain = {s["name"]: s for s in (await _info(http, "plain"))["services"]}
    spool = {s["name"]: s for s in (await _info(http, "spool"))["services"]}
    assert list(spool) == STANDARD  # still last, in its place
    assert spool["connect_port"]["doc"] == FEED_DOC
    assert {**spool["connect_port"], "doc": ""} == {**plain["connect_port"], "doc": ""}
    connected = await _send(http, "spool", "connect_port", {"local": "Feed", "remote": "plain/Rope"})
    assert connected["status"] == "done"
    wrong = await _send(http, "spool", "connect_port", {"local": "Rope", "remote": "plain/Rope"})
    assert wrong["exception"] == {"ex": "::genom::no_such_inport"}
    unknown = await _send(http, "spool", "abort_activity", {"activity": 77})
    assert unknown["exception"] == {"ex": "::genom::no_such_activity"}
