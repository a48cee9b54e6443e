"""A module's ``/info`` is described and encoded once per loaded instance, and answered with the same bytes after.

``Component.description`` describes an instance at its first call and keeps it;
the gateway keeps the encoded body beside the description it encodes
(``gateway/_info_bodies.py``).  These tests count the descriptions made while a
gateway answers, compare the bodies byte for byte with a description made
afresh, and check what makes a new one: an instance loaded again, and an
instance that describes itself with a new object (as a replay does once its
recording's ports are known).
"""

from __future__ import annotations

import json
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from aiogenomix.components.core import Component, ComponentHost, ScaledClock, _describe
from aiogenomix.components.demo import Demo
from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.gateway._replies import dumps


class Relabelled(Demo, name="relabelled", version="1.0"):
    """A demo robot whose description's ``doc`` can be changed while it is loaded."""

    label = "first"
    _relabelled: dict[str, Any] | None = None

    def description(self) -> dict[str, Any]:
        """The demo's description with this instance's label as its ``doc`` (a new object when it changes)."""
        if self._relabelled is None or self._relabelled["doc"] != self.label:
            self._relabelled = {**super().description(), "doc": self.label}
        return self._relabelled


@pytest.fixture
def described(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The instances described, one entry per description made."""
    made: list[str] = []
    original = _describe.describe

    def describe(component: Component) -> dict[str, Any]:
        made.append(component.instance)
        return original(component)

    monkeypatch.setattr(_describe, "describe", describe)
    return made


@pytest.fixture
async def served() -> AsyncIterator[tuple[ComponentHost, aiohttp.ClientSession]]:
    async with ComponentHost(clock=ScaledClock(1), factories={"demo": Demo, "relabelled": Relabelled}) as host:
        async with serve(GatewayConfig.of(port=0), host=host) as url, aiohttp.ClientSession(url) as http:
            yield host, http


async def info(http: aiohttp.ClientSession, module: str) -> bytes:
    async with http.get(f"/module/{module}/info") as reply:
        assert (reply.status, reply.content_type) == (200, "application/json")
        return await reply.read()


async def test_a_second_info_answers_the_same_bytes_described_once(
        served: tuple[ComponentHost, aiohttp.ClientSession], described: list[str]) -> None:
    host, http = served
    await host.load("demo")
    first = await info(http, "demo")
    second = await info(http, "demo")
    assert second == first
    assert described == ["demo"]
    assert first == dumps(_fresh(host, "demo"))  # what a description made now says
    assert described == ["demo", "demo"]


def _fresh(host: ComponentHost, instance: str) -> dict[str, Any]:
    """A description of *instance* made now, not the kept one."""
    component = host.get(instance)
    assert isinstance(component, Component)
    return _describe.describe(component)


async def test_an_instance_loaded_again_is_described_again(
        served: tuple[ComponentHost, aiohttp.ClientSession], described: list[str]) -> None:
    host, http = served
    await host.load("demo")
    before = await info(http, "demo")
    await host.unload("demo")
    async with http.get("/module/demo/info") as reply:
        assert reply.status == 404  # nothing kept answers for an instance that is gone
    await host.load("demo")
    assert await info(http, "demo") == before
    assert described == ["demo", "demo"]


async def test_a_description_that_changes_is_encoded_again(
        served: tuple[ComponentHost, aiohttp.ClientSession]) -> None:
    host, http = served
    robot = await host.load("relabelled")
    assert isinstance(robot, Relabelled)
    assert json.loads(await info(http, "relabelled"))["doc"] == "first"
    robot.label = "second"
    assert json.loads(await info(http, "relabelled"))["doc"] == "second"
    assert json.loads(await info(http, "relabelled"))["doc"] == "second"
