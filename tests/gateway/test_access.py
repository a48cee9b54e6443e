"""Opt-in bearer-token auth, the component allow-list, and what the index page tells."""

from __future__ import annotations

import aiohttp
import pytest

from aiogenomix.clients import RemoteError, aconnect
from aiogenomix.gateway import GatewayConfig, serve


async def test_a_token_is_required_when_configured() -> None:
    async with serve(GatewayConfig.of(port=0, token="s3cret", audio_socket_port=0)) as url:
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{url}/version") as reply:
                assert reply.status == 401
                assert (await reply.json())["ex"] == "::genomix::unauthorized"
            async with http.get(f"{url}/version", headers={"Authorization": "Bearer wrong"}) as reply:
                assert reply.status == 401
            async with http.get(f"{url}/version", headers={"Authorization": "Bearer s3cret"}) as reply:
                assert reply.status == 200
        async with aconnect(url, token="s3cret") as client:
            demo = await client.load("demo")
            assert await demo.GetSpeed() == "::demo::SLOW"


async def test_only_allowed_components_load() -> None:
    async with serve(GatewayConfig.of(port=0, components=["demo"], audio_socket_port=0)) as url:
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{url}/") as reply:
                index = await reply.json()
            assert index["available"] == ["demo"]
            assert set(index["features"]) >= {"binary", "since", "watch", "wait"}
            async with http.get(f"{url}/load/kemar") as reply:
                assert reply.status == 404
            async with http.get(f"{url}/load/demo") as reply:
                assert reply.status == 200
        async with aconnect(url) as client:
            with pytest.raises(RemoteError):
                await client.load("countserver")
