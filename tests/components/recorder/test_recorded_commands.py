"""Issue 33, acceptance 2 (its first half): a recording keeps what was commanded when, beside the ports.

A session moves the KEMAR head while the recorder records its state: the recording holds each
request of the session (service, input, status, when it was sent and when it ended, on the rig's
clock), read back with the ``mcap`` library and as ``foxglove_msgs/msg/Log`` lines with ``rosbags``;
each command sits among the head states it caused; ``aiogenomix-record export`` writes them as CSV.
The rig runs on a clock the test steps: the times are exact.
"""

from __future__ import annotations

import csv
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import aiohttp
import orjson
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from aiogenomix.components.core import ComponentHost, HostSettings, ManualClock
from aiogenomix.components.recording import EVENT_COLUMNS, EVENTS_SCHEMA
from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.record import main as record_main


@pytest.fixture
async def rig(tmp_path: Path) -> AsyncIterator[tuple[aiohttp.ClientSession, ManualClock, Path]]:
    """A gateway whose rig runs on a clock the test steps, recordings allowed in a directory of the test."""
    clock = ManualClock(start=1_700_000_000.0)
    settings = HostSettings(can_timeout=10.0, audio_socket_port=0, record_dirs=(str(tmp_path),))
    async with ComponentHost(clock=clock, settings=settings) as host, serve(GatewayConfig.of(port=0), host) as url, \
            aiohttp.ClientSession(base_url=url) as http:
        for name in ("kemar", "recorder"):
            async with http.get(f"/load/{name}") as loaded:
                assert loaded.status == 200, await loaded.text()
        yield http, clock, tmp_path


async def send(http: aiohttp.ClientSession, module: str, service: str, inputs: dict[str, Any],
               session: str) -> dict[str, Any]:
    params = {"input": orjson.dumps(inputs).decode(), "s": session}
    async with http.get(f"/module/{module}/send/{service}", params=params) as sent:
        return await sent.json()  # type: ignore[no-any-return]


async def call(http: aiohttp.ClientSession, clock: ManualClock, module: str, service: str,
               inputs: dict[str, Any], session: str) -> dict[str, Any]:
    """Send a request in *session* and run the rig's time until it has ended; return its final status."""
    status = await send(http, module, service, inputs, session)
    if status["status"] != "sent":
        return status

    async def ended() -> dict[str, Any]:
        async with http.get(f"/module/{module}/wait/{status['id']}", params={"timeout": "600"}) as waited:
            return await waited.json()  # type: ignore[no-any-return]

    return await clock.run_until(ended())


async def test_a_recording_holds_each_command_of_its_session_at_its_time(
        rig: tuple[aiohttp.ClientSession, ManualClock, Path]) -> None:
    http, clock, directory = rig
    assert (await call(http, clock, "kemar", "Homing", {}, "lab"))["status"] == "done"
    start = await send(http, "recorder", "Start", {"path": "moves.mcap", "ports": ["kemar/currentState"]}, "lab")
    assert start["status"] == "sent", start
    await clock.advance(0.5)
    moves: list[tuple[float, float, str, float]] = []      # (target, sent at, id, ended at)
    for target in (30.0, -40.0):
        at = clock.wall()
        moved = await call(http, clock, "kemar", "MoveAbsolutePosition", {"target": target}, "lab")
        assert moved["status"] == "done", moved
        moves.append((target, at, moved["id"], clock.wall()))
        await clock.advance(0.5)
    # A command refused is recorded too, with its exception.
    refused = await call(http, clock, "recorder", "Start", {"path": "again.mcap", "ports": ["kemar/currentState"]},
                         "lab")
    assert refused["exception"]["ex"] == "::recorder::ALREADY_RECORDING"
    # Another session's command is not this recording's.
    other_at = clock.wall()
    assert (await call(http, clock, "kemar", "MoveAbsolutePosition", {"target": 10}, "other"))["status"] == "done"
    assert (await call(http, clock, "recorder", "Stop", {}, "lab"))["status"] == "done"
    path = directory / "moves.mcap"

    # -- read back with the mcap library: the events as JSON, the head states beside them -----------
    records: list[tuple[int, dict[str, Any]]] = []
    states: list[tuple[float, float]] = []                  # (rig time, azimuth)
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        channels = {c.topic: c for c in reader.get_summary().channels.values()}   # type: ignore[union-attr]
        assert orjson.loads(channels["/events"].metadata["aiogenomix.jsonschema"]) == EVENTS_SCHEMA
        assert channels["/events"].metadata["aiogenomix.events"] == "lab"
        for _, channel, message in reader.iter_messages(topics=["/events", "/kemar/currentState"]):
            if channel.topic == "/events":
                records.append((message.publish_time, orjson.loads(message.data)))
            else:
                states.append((message.publish_time * 1e-9, orjson.loads(message.data)["position"]))
        log = [(message.publish_time, decoded) for _, _, message, decoded
               in reader.iter_decoded_messages(topics=["/events/log"])]
    commands = [(time, r) for time, r in records if r["event"] == "request" and r["instance"] == "kemar"]
    assert [(r["input"]["target"], r["status"], r["session"]) for _, r in commands] == [
        (30.0, "sent", "lab"), (30.0, "done", "lab"), (-40.0, "sent", "lab"), (-40.0, "done", "lab")]
    assert all(r["service"] == "MoveAbsolutePosition" for _, r in commands)
    for index, (target, sent_at, request_id, ended_at) in enumerate(moves):
        (sent_ns, sent), (done_ns, done) = commands[2 * index], commands[2 * index + 1]
        assert sent["id"] == done["id"] == request_id
        # Each command at its time on the rig's clock: when it was sent; it ended before the client heard so.
        assert sent_ns * 1e-9 == pytest.approx(sent_at, abs=1e-6) and sent["time"] == pytest.approx(sent_at)
        assert sent_at < done_ns * 1e-9 <= ended_at + 1e-6 and done["sent"] == pytest.approx(sent_at)
        # ... among the head states it caused: at its sending the head was elsewhere, at its end at the target.
        # (The head publishes its state as it moves; the recorder reads it when it can: publications it
        # missed are coalesced, never reordered.)
        following = moves[index + 1][1] if index + 1 < len(moves) else other_at
        before = [azimuth for time, azimuth in states if time <= sent_at]
        after = [azimuth for time, azimuth in states if sent_at < time < following]
        assert before and abs(before[-1] - target) > 20
        assert after and after[-1] == pytest.approx(target, abs=0.5)
    errors = [r for _, r in records if r.get("status") == "error"]
    assert [(r["id"], r["service"], r["input"]["path"], r["exception"]) for r in errors] == [
        (refused["id"], "Start", "again.mcap", refused["exception"])]
    assert not [r for _, r in records if r.get("session") == "other"]
    # The same events as log lines, at the same times, an error at the error level.
    lines = [(time, entry.message, entry.level) for time, entry in log if entry.name == "kemar"]
    assert [time for time, _, _ in lines] == [time for time, _ in commands]
    # (The input as the component ran it: its defaults too.)
    assert lines[0][1] == f'{moves[0][2]} MoveAbsolutePosition {{"target":30.0,"velocity":0.0}} sent [lab]'
    assert [level for _, _, level in lines] == [2, 2, 2, 2]
    assert [entry.level for _, entry in log if "ALREADY_RECORDING" in entry.message] == [4]

    # -- with rosbags, as ROS 2 tools read it -----------------------------------------------------
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as bag:
        connections = [c for c in bag.connections if c.topic == "/events/log"]
        assert [c.msgtype for c in connections] == ["foxglove_msgs/msg/Log"]
        messages = [bag.deserialize(raw, c.msgtype).message for c, _, raw in bag.messages(connections=connections)]
    assert [line for _, line, _ in lines] == [m for m in messages if m.startswith("kemar::")]

    # -- exported as CSV -------------------------------------------------------------------------
    assert record_main(["export", str(path), "-o", str(directory / "out")]) == 0
    with open(directory / "out" / "events.csv", newline="") as table:
        rows = list(csv.DictReader(table))
    assert tuple(rows[0]) == EVENT_COLUMNS
    moved = [row for row in rows if row["service"] == "MoveAbsolutePosition"]
    assert [(float(row["time_s"]), row["id"], orjson.loads(row["input"])["target"], row["status"])
            for row in moved] == [
        (pytest.approx(at), request_id, target, status)
        for target, sent_at, request_id, ended_at in moves for at, status in ((sent_at, "sent"), (ended_at, "done"))]
    assert all(float(row["sent_time_s"]) == pytest.approx(moves[i // 2][1]) for i, row in enumerate(moved))
    failed = [row for row in rows if row["status"] == "error"]
    assert [(row["service"], orjson.loads(row["exception"])) for row in failed] == [("Start", refused["exception"])]


async def test_a_recording_keeps_every_session_s_commands_or_none(
        rig: tuple[aiohttp.ClientSession, ManualClock, Path]) -> None:
    http, clock, directory = rig
    assert (await call(http, clock, "kemar", "Homing", {}, "lab"))["status"] == "done"
    for events, name in (("all", "all.mcap"), ("none", "none.mcap")):
        assert (await send(http, "recorder", "Start", {"path": name, "ports": ["kemar/currentState"],
                                                       "events": events}, "lab"))["status"] == "sent"
        await clock.advance(0.1)
        assert (await call(http, clock, "kemar", "MoveAbsolutePosition", {"target": 5}, "other"))["status"] == "done"
        assert (await call(http, clock, "recorder", "Stop", {}, "lab"))["status"] == "done"
    with open(directory / "all.mcap", "rb") as stream:
        topics = {c.topic for c in make_reader(stream).get_summary().channels.values()}  # type: ignore[union-attr]
        stream.seek(0)
        recorded = [orjson.loads(m.data) for _, _, m in make_reader(stream).iter_messages(topics=["/events"])]
    assert {"/events", "/events/log"} <= topics
    assert [(r["session"], r["status"]) for r in recorded if r.get("service") == "MoveAbsolutePosition"] == [
        ("other", "sent"), ("other", "done")]
    with open(directory / "none.mcap", "rb") as stream:
        topics = {c.topic for c in make_reader(stream).get_summary().channels.values()}  # type: ignore[union-attr]
    assert topics == {"/kemar/currentState", "/kemar/currentState/joint_state"}
    # A word the recorder does not know is refused before any file.
    refused = await call(http, clock, "recorder", "Start", {"path": "x.mcap", "ports": ["kemar/currentState"],
                                                            "events": "everything"}, "lab")
    assert refused["exception"]["ex"] == "::recorder::BAD_RECORDING"
    assert "events is one of session, all, none" in refused["exception"]["detail"]["what"]
    assert not (directory / "x.mcap").exists()
