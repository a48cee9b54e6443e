"""The KEMAR head in its own component host (its virtual CAN bus and simulated drive with it)."""

from __future__ import annotations

import json

import aiohttp
import pytest

from aiogenomix.clients import aconnect
from tests.gateway.test_kemar_over_http import homed_head_moves_and_reports_its_state

from ._processes import Process, start_host_and_gateway


async def test_homing_and_moves_of_a_remote_head(started: list[Process]) -> None:
    # A reply bound for a busy machine: the simulated drive answers from a thread of the host process.
    _, url, _ = await start_host_and_gateway(started, ["kemar"], extra=["--time-scale", "50", "--can-timeout", "10"])
    async with aconnect(url, timeout=30) as client:
        kemar = await client.load("kemar")
        with pytest.raises(kemar.NOT_HOMED):  # the component's own exception class, generated from /info
            await kemar.MoveAbsolutePosition(10)
        await homed_head_moves_and_reports_its_state(kemar)

    # The head's state can be watched as it moves, publication by publication.
    async with aiohttp.ClientSession(base_url=url) as http:
        move = await http.get("/module/kemar/send/MoveAbsolutePosition", params={"input": json.dumps({"target": 45})})
        assert (await move.json())["status"] == "sent"
        positions = []
        async with http.get("/module/kemar/watch/currentState") as stream:
            async for line in stream.content:
                if line.startswith(b"data: "):
                    positions.append(json.loads(line[6:])["currentState"]["position"])
                    if positions[-1] == pytest.approx(45, abs=0.1):
                        break
        assert len(positions) > 1 and positions == sorted(positions)
