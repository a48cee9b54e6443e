"""Issue 9, acceptance 3: basc reads consecutive blocks from bass through its in port, and counts what it lost."""

from __future__ import annotations

import itertools

import numpy as np

from aiogenomix.components.basc import Basc, BlockReport
from aiogenomix.components.bass import Bass
from aiogenomix.components.core import ComponentHost

from .conftest import reference_frames, wait_for_frame


async def loaded_basc(host: ComponentHost) -> Basc:
    basc = await host.load("basc")
    assert isinstance(basc, Basc)
    connect = await basc.send("connect_port", {"local": "Audio", "remote": "bass/Audio"})
    assert connect.status == "done"
    return basc


async def collect_blocks(basc: Basc, request_done: object) -> list[BlockReport]:
    """Every Blocks publication of one GetBlocks, awaited one by one (never polled)."""
    reports: list[BlockReport] = []
    version = basc.Blocks.version
    while True:
        version = await basc.Blocks.wait_published(version)
        report = basc.Blocks.read()
        if report.blocks:
            reports.append(report)
        if request_done():  # type: ignore[operator]
            return reports


async def test_five_blocks_are_consecutive_and_complete(host: ComponentHost, bass: Bass) -> None:
    basc = await loaded_basc(host)
    bass.head_azimuth = lambda: 0.0
    await bass.send("Acquire", {"device": "sim"})
    await wait_for_frame(bass, 12000)
    request = await basc.send("GetBlocks", {"nBlocks": 5})
    reports = await collect_blocks(basc, lambda: not request.running)
    await request.ended.wait()
    assert request.status == "done" and request.output == {"nBlocks": 0}
    assert [r.blocks for r in reports] == [1, 2, 3, 4, 5]
    starts = [r.firstFrameIndex for r in reports]
    assert np.diff(starts).tolist() == [12000] * 4 and all(r.nFrames == 12000 for r in reports)
    assert all(r.lost == 0 for r in reports)
    # Each block holds exactly the frames of the scene under those indices (frame f is sample f - 1).
    reference = reference_frames(starts[-1] + 12000)
    for report in reports:
        np.testing.assert_array_equal(report.left, reference[report.firstFrameIndex - 1:][:12000, 0])
        np.testing.assert_array_equal(report.right, reference[report.firstFrameIndex - 1:][:12000, 1])
    await bass.send("Stop")


async def test_a_period_too_slow_for_the_block_size_reports_the_loss(host: ComponentHost, bass: Bass) -> None:
    basc = await loaded_basc(host)
    # 2205-frame chunks, 4 on the port: 200 ms of audio.  Blocks of 1000 frames read once per 250 ms
    # period take in 4000 frames a second of the 44100 produced: the reader falls behind the port.
    await bass.send("Acquire", {"device": "sim", "nChunksOnPort": 4})
    await wait_for_frame(bass, 4 * 2205)
    request = await basc.send("GetBlocks", {"nBlocks": 12, "nFramesPerBlock": 1000, "startOffs": 0})
    reports = await collect_blocks(basc, lambda: not request.running)
    assert request.status == "done"
    assert reports[-1].lost > 0
    # Every jump between consecutive blocks is counted (a loss may also fall inside a block).
    jumps = sum(b.firstFrameIndex - (a.firstFrameIndex + a.nFrames) for a, b in itertools.pairwise(reports))
    assert 0 < jumps <= reports[-1].lost
    await bass.send("Stop")


async def test_no_data_without_a_connection_or_an_acquisition(host: ComponentHost, bass: Bass) -> None:
    basc = await host.load("basc")
    unconnected = await basc.send("GetBlocks")
    await unconnected.ended.wait()
    assert unconnected.exception == {"ex": "::basc::e_noData",
                                     "detail": {"what": "the Audio port is not connected to bass/Audio"}}
    await basc.send("connect_port", {"local": "Audio", "remote": "bass/Audio"})
    idle = await basc.send("GetBlocks")
    await idle.ended.wait()
    assert idle.exception is not None and idle.exception["ex"] == "::basc::e_noData"
    assert "Acquire" in idle.exception["detail"]["what"]


async def test_stop_interrupts_an_endless_get_blocks(host: ComponentHost, bass: Bass) -> None:
    basc = await loaded_basc(host)
    await bass.send("Acquire", {"device": "sim"})
    await wait_for_frame(bass, 2205)
    endless = await basc.send("GetBlocks", {"nBlocks": 0, "nFramesPerBlock": 2205})
    version = basc.Blocks.version
    while basc.Blocks.read().blocks < 3:
        version = await basc.Blocks.wait_published(version)
    stop = await basc.send("Stop")
    await endless.ended.wait()
    assert stop.status == "done" and endless.exception == {"ex": "::genom::interrupted", "detail": {"by": "Stop"}}
    await bass.send("Stop")


async def test_a_new_get_blocks_interrupts_the_running_one(host: ComponentHost, bass: Bass) -> None:
    basc = await loaded_basc(host)
    await bass.send("Acquire", {"device": "sim"})
    await wait_for_frame(bass, 2205)
    first = await basc.send("GetBlocks", {"nBlocks": 0})
    second = await basc.send("GetBlocks", {"nBlocks": 1, "nFramesPerBlock": 2205, "startOffs": -2205})
    await first.ended.wait()
    assert first.exception == {"ex": "::genom::interrupted", "detail": {"by": "GetBlocks"}}
    await second.ended.wait()
    assert second.status == "done" and second.output == {"nBlocks": 0}
    await bass.send("Stop")
