"""Zenoh's shared memory: only for large messages, and what a killed process leaves in /dev/shm is removed."""

from __future__ import annotations

import fcntl
import json
import os
import pathlib
import signal
import time
import urllib.parse

import aiohttp
import pytest

from aiogenomix.remote._session import ZenohSettings
from aiogenomix.remote._shm import POOL_SIZE, SHM_FOLDER, THRESHOLD, remove_orphaned_segments

from ._processes import Process, free_port, start_component_host, start_gateway

_THRESHOLD_KEY = "transport/shared_memory/transport_optimization/message_size_threshold"
_POOL_KEY = "transport/shared_memory/transport_optimization/pool_size"


def test_large_messages_only_unless_the_configuration_file_says_otherwise(tmp_path: pathlib.Path) -> None:
    config = ZenohSettings(listen=["tcp/127.0.0.1:7447"]).config()
    assert (config.get_json(_THRESHOLD_KEY), config.get_json(_POOL_KEY)) == (str(THRESHOLD), str(POOL_SIZE))
    own = tmp_path / "own.json5"
    own.write_text("{transport: {shared_memory: {transport_optimization: {pool_size: 16777216}}}}")
    config = ZenohSettings(listen=["tcp/127.0.0.1:7447"], config_file=str(own)).config()
    assert (config.get_json(_THRESHOLD_KEY), config.get_json(_POOL_KEY)) == (str(THRESHOLD), "16777216")


def _segment(folder: pathlib.Path, name: str, age: float) -> pathlib.Path:
    path = folder / name
    path.write_bytes(b"\0" * 4096)
    then = time.time() - age
    os.utime(path, (then, then))
    return path


def test_only_the_segments_nobody_holds_are_removed(tmp_path: pathlib.Path) -> None:
    orphan = _segment(tmp_path, "1203788319.zenoh", age=60)
    held = _segment(tmp_path, "2466695772.zenoh", age=60)
    fresh = _segment(tmp_path, "2815.zenoh", age=0)  # its maker may be about to lock it
    other = _segment(tmp_path, "jack_db-0", age=60)
    with held.open("rb") as holder:
        fcntl.flock(holder, fcntl.LOCK_SH)  # as a running Zenoh process holds each segment it made or maps
        assert remove_orphaned_segments(tmp_path) == ["1203788319.zenoh"]
    assert not orphan.exists() and held.exists() and fresh.exists() and other.exists()


def _segments_of(pid: int) -> set[str]:
    """The Zenoh segments process *pid* maps."""
    maps = pathlib.Path(f"/proc/{pid}/maps").read_text()
    return {pathlib.Path(line.split()[-1]).name for line in maps.splitlines() if line.endswith(".zenoh")}


async def test_a_killed_host_s_segments_are_removed_by_the_next_process_to_start(
        tmp_path: pathlib.Path, started: list[Process]) -> None:
    if not SHM_FOLDER.is_dir():
        pytest.skip(f"no {SHM_FOLDER} here")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    host = await start_component_host(["capture"], listen=endpoint, extra=["--time-scale", "1"])
    started.append(host)
    gateway, url = await start_gateway([endpoint])
    started.append(gateway)
    async with aiohttp.ClientSession(base_url=url) as http:
        assert (await http.get("/load/capture")).status == 200
        start = {"device": "sim", "transfer_rate": 44100, "chunk_time": 50, "Port_chunks": 40}
        async with http.get(f"/module/capture/send/StartCapture?input={urllib.parse.quote(json.dumps(start))}"):
            pass
        # A window's whole data (40 chunks, 700 kB) is past the threshold: the host makes its pool for it.
        async with http.get("/module/capture/read/Port", params={"format": "binary"}) as reply:
            assert reply.status == 200
    segments = _segments_of(host.pid)
    if not segments:
        pytest.skip("Zenoh made no shared-memory pool here (the two processes could not share memory)")
    host.kill(signal.SIGKILL)
    gateway.kill(signal.SIGKILL)
    await host.end()
    await gateway.end()
    for name in segments:  # as if killed long ago (a segment is left alone for its first seconds)
        path = SHM_FOLDER / name
        if path.exists():
            os.utime(path, (time.time() - 60, time.time() - 60))
    # The next aiogenomix process removes them, even one whose Zenoh uses no shared memory (Zenoh does not, then).
    no_shm = tmp_path / "no_shm.json5"
    no_shm.write_text("{transport: {shared_memory: {enabled: false}}}")
    started.append(await start_component_host(["demo"], listen=f"tcp/127.0.0.1:{free_port()}",
                                               extra=["--zenoh-config", str(no_shm)]))
    assert not [name for name in segments if (SHM_FOLDER / name).exists()]
