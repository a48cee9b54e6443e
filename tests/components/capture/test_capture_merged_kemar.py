"""The merged capture + KEMAR component: Table 6.3 on the wire, positions per chunk, Indexes, the turning scene."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.clients.audio_socket import AsyncAudioSocketClient
from aiogenomix.components.capture import Capture
from aiogenomix.components.core import ComponentHost, HostSettings, VirtualClock
from aiogenomix.components.kemar import Kemar
from aiogenomix.components.kemarcapture import KemarCapture, MoveIndexes

from .test_capture_binaural import interaural_delay


#: Real seconds the simulated drive has to answer (as in tests/components/kemar: a bound for a busy machine).
CAN_TIMEOUT = 10.0


@pytest.fixture
async def rig() -> AsyncIterator[ComponentHost]:
    """A host with the simulated KEMAR drive on a virtual CAN bus, on simulated time.

    The clock moves when the rig has nothing else to do, and stands still while the drive
    answers from its thread: the head and the sound are where the tests expect them however
    busy the machine.  The drive's replies are allowed the kemar tests' real-time bound, not the
    0.5 s of a real bus.  Nothing here waits for a time-out: those tests are in tests/components/kemar.
    """
    async with ComponentHost(clock=VirtualClock(),
                             settings=HostSettings(can="virtual", can_timeout=CAN_TIMEOUT, audio_socket_port=0),
                             factories={"kemarcapture": KemarCapture, "capture": Capture, "kemar": Kemar}) as host:
        yield host


@pytest.fixture
async def merged(rig: ComponentHost) -> KemarCapture:
    component = await rig.load("kemarcapture")
    assert isinstance(component, KemarCapture)
    homing = await component.send("Homing")
    await homing.ended.wait()
    assert homing.status == "done", homing.exception
    return component


async def wait_for_index(component: Capture, index: int) -> None:
    while component.Port.read().index < index:
        await component.Port.wait_published()


@pytest.fixture
def source_at_30(tmp_path: Path) -> str:
    path = tmp_path / "scene.json"
    path.write_text(json.dumps({"seed": 5, "sources": [{"type": "noise", "azimuth": 30, "level": -20}]}))
    return f"sim:{path}"


@pytest.mark.parametrize(("chunks", "size"), [(10, 176448), (20, 352888), (80, 1411528)])
async def test_table_6_3_bytes_on_the_wire(merged: KemarCapture, chunks: int, size: int) -> None:
    socket = await merged.send("DedicatedSocket")
    port = await merged.wait_socket()
    capturing = await merged.send("StartCapture", {"transfer_rate": 44100, "chunk_time": 50, "Port_chunks": chunks})
    await wait_for_index(merged, chunks + 1)
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    writer.write(b"Read Port - Index 0\n")
    header = await reader.readexactly(4)
    count = int.from_bytes(header, "little")
    rest = await reader.readexactly(size - 4)
    writer.close()
    assert count == chunks and len(header) + len(rest) == size
    positions = np.frombuffer(rest[-4 * chunks:], "<f4")
    np.testing.assert_allclose(positions, 0.0, atol=0.01)      # the homed head faces 0°
    for request in (capturing, socket):
        await merged.interrupt(request, by="test")


async def test_each_chunk_carries_the_head_position_and_moves_publish_indexes(merged: KemarCapture) -> None:
    capturing = await merged.send("StartCapture", {"Port_chunks": 400})
    await wait_for_index(merged, 2)
    move = await merged.send("MoveAbsolutePosition", {"target": 45.0, "velocity": 90.0})
    started: MoveIndexes = merged.Indexes.read()
    assert not started.arrived
    await move.ended.wait()
    arrived: MoveIndexes = merged.Indexes.read()
    assert move.status == "done", move.exception
    assert arrived.arrived and arrived.startIndex >= 2 and arrived.endIndex > arrived.startIndex
    assert arrived.startPosition == pytest.approx(0.0, abs=0.01)
    assert arrived.endPosition == pytest.approx(45.0, abs=0.05)
    await wait_for_index(merged, arrived.endIndex + 2)
    port = merged.Port.read()
    assert port.positions.shape == (400,) and port.index < 400
    held = port.positions[400 - port.index:]                   # the chunks captured so far
    assert np.all(np.diff(held) >= -1e-9)                      # the head only turned left
    assert held[0] == pytest.approx(0.0, abs=0.01) and held[-1] == pytest.approx(45.0, abs=0.05)
    assert merged.position_failures == 0
    await merged.send("StopCapture")
    await capturing.ended.wait()


async def test_an_interrupted_move_publishes_no_arrival(merged: KemarCapture) -> None:
    move = await merged.send("MoveAbsolutePosition", {"target": 80.0, "velocity": 10.0})
    while merged.Indexes.version < 2:
        await merged.Indexes.wait_published()
    await merged.send("MoveAbsolutePosition", {"target": 0.0, "velocity": 200.0})
    await move.ended.wait()
    assert move.exception is not None and move.exception["ex"] == "::genom::interrupted"


async def test_socket_positions_match_the_port(merged: KemarCapture) -> None:
    socket = await merged.send("DedicatedSocket")
    port = await merged.wait_socket()
    capturing = await merged.send("StartCapture", {"Port_chunks": 20})
    move = await merged.send("MoveAbsolutePosition", {"target": -30.0, "velocity": 60.0})
    await move.ended.wait()
    await merged.send("StopCapture")
    await capturing.ended.wait()
    async with AsyncAudioSocketClient(port=port, positions=True) as client:
        block = await client.read()
    published = merged.Port.read()
    assert block.positions is not None
    np.testing.assert_allclose(block.positions, published.positions[20 - block.count:], atol=1e-4)
    np.testing.assert_array_equal(block.left, published.left[(20 - block.count) * 2205:])
    await merged.send("CloseSocket")
    await socket.ended.wait()


async def test_turning_the_head_toward_a_source_brings_its_delay_to_zero(merged: KemarCapture,
                                                                          source_at_30: str) -> None:
    capturing = await merged.send("StartCapture", {"device": source_at_30, "Port_chunks": 8})
    await wait_for_index(merged, 8)
    before = merged.Port.read()
    assert interaural_delay(np.stack([before.left, before.right], axis=1)) >= 10   # on the left
    move = await merged.send("MoveAbsolutePosition", {"target": 30.0, "velocity": 200.0})
    await move.ended.wait()
    assert move.status == "done", move.exception
    facing = merged.Port.read().index + 9
    await wait_for_index(merged, facing)
    after = merged.Port.read()
    assert abs(interaural_delay(np.stack([after.left, after.right], axis=1))) <= 1
    assert after.positions[-1] == pytest.approx(30.0, abs=0.05)
    await merged.send("StopCapture")
    await capturing.ended.wait()


async def test_plain_capture_follows_the_kemar_component_head(rig: ComponentHost, source_at_30: str) -> None:
    kemar = await rig.load("kemar")
    capture = await rig.load("capture")
    assert isinstance(capture, Capture)
    homing = await kemar.send("Homing")
    await homing.ended.wait()
    move = await kemar.send("MoveAbsolutePosition", {"target": -30.0, "velocity": 200.0})
    await move.ended.wait()
    capturing = await capture.send("StartCapture", {"device": source_at_30, "Port_chunks": 8})
    await wait_for_index(capture, 8)
    port = capture.Port.read()
    # The source is 60° to the left of a head turned to -30°.
    assert interaural_delay(np.stack([port.left, port.right], axis=1)) >= 19
    await capture.send("StopCapture")
    await capturing.ended.wait()


async def test_one_head_moving_kemar_updates_the_state_kemarcapture_shows(rig: ComponentHost,
                                                                          merged: KemarCapture) -> None:
    kemar = await rig.load("kemar")
    assert isinstance(kemar, Kemar)
    moved = await kemar.send("MoveAbsolutePosition", {"target": -30})
    await moved.ended.wait()
    assert moved.status == "done", moved.exception
    # One head: the merged component's port shows where kemar turned it, read at the same time.
    mine, theirs = kemar.currentState.read(), merged.currentState.read()
    assert theirs.position == pytest.approx(-30.0, abs=0.1)
    assert theirs == mine
    position = await merged.send("GetPosition")
    await position.ended.wait()
    assert position.output is not None and position.output["position"] == pytest.approx(-30.0, abs=0.1)
    # And the other way round: a reading by the merged component shows on kemar's port.
    assert kemar.currentState.read() == merged.currentState.read()
    await rig.unload("kemar")
    moved = await merged.send("MoveAbsolutePosition", {"target": 10})
    await moved.ended.wait()
    assert merged.currentState.read().position == pytest.approx(10.0, abs=0.1)
