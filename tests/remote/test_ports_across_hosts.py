"""``connect_port`` across processes: ``countclient`` in one host reads ``countserver`` of another."""

from __future__ import annotations

import asyncio
from collections.abc import Sequence

import pytest

from aiogenomix.clients import Interrupted, RemoteError, aconnect

from ._processes import Process, free_port, start_component_host, start_gateway


async def reader_and_writer_hosts(started: list[Process], *, writer: str, reader: str,
                                  extra: Sequence[str] = ()) -> str:
    """Component *writer* in one host, *reader* in another that connects to it, and a gateway of both.

    *extra* are more options of both hosts. Returns the gateway's URL.
    """
    writer_endpoint = f"tcp/127.0.0.1:{free_port()}"
    reader_endpoint = f"tcp/127.0.0.1:{free_port()}"
    started.append(await start_component_host([writer], listen=writer_endpoint, extra=extra))
    started.append(await start_component_host([reader], listen=reader_endpoint, connect=[writer_endpoint],
                                              extra=extra))
    gateway, url = await start_gateway([writer_endpoint, reader_endpoint])
    started.append(gateway)
    return url


async def test_countclient_in_one_host_fed_by_countserver_in_another(started: list[Process]) -> None:
    url = await reader_and_writer_hosts(started, writer="countserver", reader="countclient")
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


async def test_basc_in_one_host_reads_blocks_of_bass_in_another(started: list[Process]) -> None:
    # Real time: the ten seconds bass's window holds stay ten seconds while the test compares (at the suite's
    # 20 times real time they were half a second of a busy machine, and the block could leave the window).
    url = await reader_and_writer_hosts(started, writer="bass", reader="basc", extra=["--time-scale", "1"])
    async with aconnect(url) as client:
        bass = await client.load("bass")
        basc = await client.load("basc")
        await basc.connect_port("Audio", "bass/Audio")
        # Before its first chunk bass holds no frames: GetBlocks would rightly refuse (e_noData).
        with pytest.raises(RemoteError) as refused:
            await basc.GetBlocks(nBlocks=1)
        assert refused.value.ex == "::basc::e_noData"
        # Ten seconds on the port: the last block is still there when the test compares it.
        acquiring = await bass.Acquire(device="sim", nChunksOnPort=200, ack=True)
        async with asyncio.timeout(30):
            while (await bass.Audio()).lastFrameIndex < 4 * 12000:
                await asyncio.sleep(0.02)
        # Three consecutive half-second blocks, read across processes from the frame-indexed port.
        assert await basc.GetBlocks(nBlocks=3, nFramesPerBlock=22050, startOffs=0) == 0
        blocks = await basc.Blocks()
        assert (blocks.blocks, blocks.nFrames, blocks.lost) == (3, 22050, 0)
        assert len(blocks.left) == len(blocks.right) == 22050
        # The last block is what bass itself holds under those frame indices.
        window = await bass.Audio()
        first = window.lastFrameIndex - window.nFramesPerChunk * window.nChunksOnPort + 1
        offset = blocks.firstFrameIndex - first
        assert offset >= 0
        assert list(blocks.left) == list(window.left[offset:offset + 22050])
        assert list(blocks.right) == list(window.right[offset:offset + 22050])
        await bass.Stop()
        with pytest.raises(Interrupted):
            await acquiring
