"""Issue 29, items 3 and 4: a recording has budgets, is its owner's to read, and names no path of the host.

Over HTTP, as the issue's repro: ``recorder/send/Start`` with no duration used to run until the
disk was full, 64 recorders could run at once, files were world-readable and replies gave the
file's full path on the host.  Now each budget of the host (``--max-recordings``,
``--max-recording-seconds``, ``--max-recording-bytes``, ``--max-record-dir-bytes``) refuses or
ends a recording with ``::recorder::OVER_BUDGET`` naming its flag, the file stays readable (by
the ``mcap`` library and ``rosbags``), files are created ``0600`` (or ``--record-mode``), and
replies name the file within its record directory.  The rig runs on a clock the test steps.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import aiohttp
import orjson
import pytest
from mcap.reader import make_reader

from aiogenomix.components.core import Budgets, ComponentHost, HostSettings, ManualClock
from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.gateway.__main__ import parse_args


MIB = 2**20
Rig = tuple[aiohttp.ClientSession, ManualClock, Path]


@contextlib.contextmanager
def umask(mask: int) -> Iterator[None]:
    old = os.umask(mask)
    try:
        yield
    finally:
        os.umask(old)


@contextlib.asynccontextmanager
async def rig(tmp_path: Path, budgets: Budgets = Budgets(), record_mode: int = 0o600) -> AsyncIterator[Rig]:
    """A gateway capturing the simulated scene on a stepped clock, recordings allowed in tmp_path/records."""
    records = tmp_path / "records"
    records.mkdir(exist_ok=True)
    clock = ManualClock()
    settings = HostSettings(can_timeout=10.0, audio_socket_port=0, record_dirs=(str(records),), budgets=budgets,
                            record_mode=record_mode)
    async with ComponentHost(clock=clock, settings=settings) as host, serve(GatewayConfig.of(port=0), host) as url, \
            aiohttp.ClientSession(base_url=url) as http:
        for name in ("capture", "recorder"):
            async with http.get(f"/load/{name}") as loaded:
                assert loaded.status == 200, await loaded.text()
        async with http.get("/module/capture/send/StartCapture", params={"input": '{"device":"sim"}'}) as started:
            assert (await started.json())["status"] == "sent"
        await clock.advance(0.2)
        yield http, clock, records


async def send(http: aiohttp.ClientSession, module: str, service: str, inputs: dict[str, Any],
               session: str | None = None) -> tuple[dict[str, Any], str]:
    """Send a request; return its status and the reply's text as sent."""
    params = {"input": orjson.dumps(inputs).decode(), **({"s": session} if session else {})}
    async with http.get(f"/module/{module}/send/{service}", params=params) as reply:
        text = await reply.text()
    return orjson.loads(text), text


async def ended(http: aiohttp.ClientSession, clock: ManualClock, module: str, request_id: str) -> dict[str, Any]:
    """The request's final status, the rig's time run until it has ended (a refusal of an activity ends it)."""
    async def waited() -> dict[str, Any]:
        async with http.get(f"/module/{module}/wait/{request_id}", params={"timeout": "600"}) as reply:
            status: dict[str, Any] = await reply.json()
            return status

    return await clock.run_until(waited())


def readable(path: Path) -> int:
    """Check a recording a budget ended: the mcap reader and rosbags open it; return its audio messages."""
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
        assert summary is not None and summary.statistics is not None
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as bag:
        frames = [c for c in bag.connections if c.topic == "/capture/Port/frames"]
        return sum(1 for _ in bag.messages(connections=frames))


def over_budget(status: dict[str, Any], flag: str) -> dict[str, Any]:
    assert status["status"] == "error", status
    assert status["exception"]["ex"] == "::recorder::OVER_BUDGET", status
    detail: dict[str, Any] = status["exception"]["detail"]
    assert detail["flag"] == flag and flag in detail["what"]
    return detail


async def test_a_recording_until_stop_ends_at_its_byte_budget_with_a_readable_file(tmp_path: Path) -> None:
    async with rig(tmp_path, Budgets(recording_bytes=3 * MIB)) as (http, clock, records):
        # The repro: no duration, so it ran until the disk was full.
        status, _ = await send(http, "recorder", "Start", {"path": "fill.mcap", "ports": ["capture/Port"]})
        detail = over_budget(await ended(http, clock, "recorder", status["id"]), "--max-recording-bytes")
    size = (records / "fill.mcap").stat().st_size
    assert 2 * MIB < size <= 3 * MIB and detail["bytes"] == size
    assert detail["path"] == "fill.mcap" and detail["seconds"] > 5
    assert readable(records / "fill.mcap") > 100


async def test_a_record_directory_is_bounded_for_every_recording_in_it_together(tmp_path: Path) -> None:
    budgets = Budgets(record_dir_bytes=6 * MIB)
    (tmp_path / "records" / "older").mkdir(parents=True)
    (tmp_path / "records" / "older" / "take.mcap").write_bytes(b"\0" * MIB)   # counted, in a subdirectory too
    async with rig(tmp_path, budgets) as (http, clock, records):
        async with http.get("/load/recorder", params={"argv": "-i second"}) as loaded:
            assert loaded.status == 200
        first, _ = await send(http, "recorder", "Start", {"path": "a.mcap", "ports": ["capture/Port"]})
        second, _ = await send(http, "second", "Start", {"path": "b.mcap", "ports": ["capture/Port"]})
        over_budget(await ended(http, clock, "recorder", first["id"]), "--max-record-dir-bytes")
        over_budget(await ended(http, clock, "second", second["id"]), "--max-record-dir-bytes")
        together = sum(f.stat().st_size for f in records.rglob("*") if f.is_file())
        assert 4 * MIB < together <= 6 * MIB   # each ended when its next chunk (up to 1 MiB) did not fit
        assert readable(records / "a.mcap") > 20 and readable(records / "b.mcap") > 20
        # Full: the next recording is refused before any file is made.
        refused, _ = await send(http, "recorder", "Start", {"path": "c.mcap", "ports": ["capture/Port"]})
        detail = over_budget(await ended(http, clock, "recorder", refused["id"]), "--max-record-dir-bytes")
        assert detail["bytes"] == 0 and not (records / "c.mcap").exists()


async def test_recordings_at_once_are_bounded_over_every_recorder(tmp_path: Path) -> None:
    async with rig(tmp_path, Budgets(recordings=2)) as (http, clock, records):
        for name in ("second", "third"):
            async with http.get("/load/recorder", params={"argv": f"-i {name}"}) as loaded:
                assert loaded.status == 200
        running = [(await send(http, name, "Start", {"path": f"{name}.mcap", "ports": ["capture/Port"]}))[0]
                   for name in ("recorder", "second")]
        assert [r["status"] for r in running] == ["sent", "sent"]
        refused, _ = await send(http, "third", "Start", {"path": "third.mcap", "ports": ["capture/Port"]})
        detail = over_budget(await ended(http, clock, "third", refused["id"]), "--max-recordings")
        assert detail["what"] == "2 recordings run on this host, the most --max-recordings allows: stop one first"
        assert not (records / "third.mcap").exists()
        await clock.run_until(send(http, "second", "Stop", {}))
        assert (await ended(http, clock, "second", running[1]["id"]))["status"] == "done"
        again, _ = await send(http, "third", "Start", {"path": "third.mcap", "ports": ["capture/Port"],
                                                       "duration": 1})
        assert (await ended(http, clock, "third", again["id"]))["status"] == "done"
        await clock.run_until(send(http, "recorder", "Stop", {}))


async def test_a_recording_is_bounded_in_time(tmp_path: Path) -> None:
    async with rig(tmp_path, Budgets(recording_seconds=5)) as (http, clock, records):
        refused, _ = await send(http, "recorder", "Start", {"path": "long.mcap", "ports": ["capture/Port"],
                                                            "duration": 6})
        detail = over_budget(refused, "--max-recording-seconds")
        assert detail["what"] == "a duration of 6 s is longer than the 5 s of --max-recording-seconds"
        assert not (records / "long.mcap").exists()
        status, _ = await send(http, "recorder", "Start", {"path": "until_stop.mcap", "ports": ["capture/Port"]})
        detail = over_budget(await ended(http, clock, "recorder", status["id"]), "--max-recording-seconds")
        assert detail["seconds"] == pytest.approx(5, abs=0.1)
        async with http.get("/module/recorder/read/Status") as read:
            assert (await read.json())["Status"]["ended"] == "over budget: --max-recording-seconds"
    assert readable(records / "until_stop.mcap") == pytest.approx(100, abs=2)   # 5 s of 50-ms chunks


async def test_recordings_are_their_owners_and_replies_name_them_within_the_record_directory(tmp_path: Path) -> None:
    with umask(0o022):   # the usual umask, under which recordings were world-readable
        async with rig(tmp_path) as (http, clock, records):
            (records / "takes").mkdir()
            status, sent = await send(http, "recorder", "Start", {"path": "takes/one.mcap",
                                                                   "ports": ["capture/Port"], "duration": 1})
            final = await ended(http, clock, "recorder", status["id"])
            async with http.get("/module/recorder/read/Status") as read:
                published = await read.text()
            async with http.get(f"/module/recorder/status/{status['id']}") as reply:
                replied = await reply.text()
    assert final["status"] == "done" and final["output"]["status"]["path"] == "takes/one.mcap"
    assert orjson.loads(published)["Status"]["path"] == "takes/one.mcap"
    for text in (sent, published, replied):
        assert str(tmp_path) not in text
    assert (records / "takes" / "one.mcap").stat().st_mode & 0o777 == 0o600


async def test_the_operators_record_mode_is_kept_whatever_the_umask(tmp_path: Path) -> None:
    with umask(0o077):
        async with rig(tmp_path, record_mode=0o640) as (http, clock, records):
            status, _ = await send(http, "recorder", "Start", {"path": "shared.mcap", "ports": ["capture/Port"],
                                                               "duration": 1})
            assert (await ended(http, clock, "recorder", status["id"]))["status"] == "done"
    assert (records / "shared.mcap").stat().st_mode & 0o777 == 0o640


@pytest.mark.parametrize(("mode", "taken"), [("640", 0o640), ("0600", 0o600), ("0o644", 0o644)])
def test_the_record_mode_flag(mode: str, taken: int) -> None:
    assert parse_args(["--record-mode", mode]).host_settings().record_mode == taken


@pytest.mark.parametrize("mode", ["755", "400", "4600", "rw", "0o9"])
def test_a_record_mode_that_is_not_read_and_write_bits_with_the_owners_is_refused(
        mode: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        parse_args(["--record-mode", mode])
    assert "is not a recording's mode" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["cut\x85short.mcap", "two\u2028lines.mcap", "take\u202egpj.mcap",
                                  "iso\u2066late.mcap"])
async def test_a_recording_name_refuses_what_a_session_name_refuses(tmp_path: Path, name: str) -> None:
    async with rig(tmp_path) as (http, clock, records):
        status, _ = await send(http, "recorder", "Start", {"path": name, "ports": ["capture/Port"], "duration": 1})
        if status["status"] == "sent":
            status = await ended(http, clock, "recorder", status["id"])
        async with http.get("/session/start", params={"s": name.removesuffix(".mcap")}) as session:
            assert session.status == 400
    assert status["status"] == "error" and status["exception"]["ex"] == "::recorder::PATH_REFUSED"
    assert "bidirectional control" in status["exception"]["detail"]["what"]
    assert list(records.iterdir()) == []


def test_the_budgets_are_flags_with_their_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        parse_args(["--help"])
    shown = " ".join(capsys.readouterr().out.split())
    for flag, default in (("--max-recordings", "4"), ("--max-recording-seconds", "14400"),
                          ("--max-recording-bytes", "4G"), ("--max-record-dir-bytes", "16G")):
        assert flag in shown and f"(default {default})" in shown.rsplit(flag, 1)[1][:200]
    config = parse_args(["--max-recordings", "2", "--max-recording-bytes", "512M", "--max-recording-seconds", "60"])
    budgets = config.rig.budgets
    assert (budgets.recordings, budgets.recording_bytes, budgets.recording_seconds) == (2, 512 * MIB, 60)
