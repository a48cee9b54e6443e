"""``connect_port`` across processes: ``countclient`` in one host reads ``countserver`` of another."""

from __future__ import annotations

import asyncio

import pytest

from aiogenomix.clients import Interrupted, RemoteError, aconnect

from ._processes import Process, free_port, start_component_host, start_gateway


async def test_countclient_in_one_host_fed_by_countserver_in_another(started: list[Process]) -> None:
    server_endpoint = f"tcp/127.0.0.1:{free_port()}"
    client_endpoint = f"tcp/127.0.0.1:{free_port()}"
    started.append(await start_component_host(["countserver"], listen=server_endpoint))
    started.append(await start_component_host(["countclient"], listen=client_endpoint, connect=[server_endpoint]))
    gateway, url = await start_gateway([server_endpoint, client_endpoint])
    started.append(gateway)
    async with aconnect(url) as client:
        countserver = await client.load("countserver")
        countclient = await client.load("countclient")
        # The in port names an out port of the other process, as it would name one of its own.
        assert await countclient.connect_port("CounterPort", "countserver/CounterPort") is None
        counting = await countserver.CountFrom(initial_value=100, ack=True)
        async with asyncio.timeout(30):
            while (displayed := await countclient.Displayed()).counter.current < 105:
                await asyncio.sleep(0.05)
        assert displayed.counter.initial == 100
        # What the client displayed is what the server published: never ahead of it.
        assert displayed.counter.current <= (await countserver.CounterPort()).current
        await countserver.CountStop()
        with pytest.raises(Interrupted):
            await counting
        # An out port that does not exist is the component's own error, across processes too.
        with pytest.raises(RemoteError) as refused:
            await countclient.connect_port("CounterPort", "countserver/Nope")
        assert refused.value.ex == "::genom::no_such_outport"
        with pytest.raises(RemoteError) as refused:
            await countclient.connect_port("CounterPort", "nobody/CounterPort")
        assert refused.value.ex == "::genom::no_such_outport"
