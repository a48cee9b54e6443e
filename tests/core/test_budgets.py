"""Issue 24: budgets and their ledgers, withdrawn port data, rate-limited log lines, unknown activities."""

from __future__ import annotations

import asyncio
import logging
from typing import Annotated, Any

import pytest

from aiogenomix.components.core import (
    Budgets, Component, ComponentHost, GenomException, HostSettings, InPort, Ledger, Long, Out, OutPort, OverBudget,
    String, ThrottledLog, activity, function, idl_struct,
)
from aiogenomix.components.core.runtime import PortUnavailable

MIB = 2**20


def test_every_bound_has_a_default_a_flag_and_a_unit() -> None:
    budgets = Budgets()
    flags = [Budgets.flag(name) for name in Budgets.names()]
    assert len(set(flags)) == len(flags) and all(flag.startswith("--max-") for flag in flags)
    assert all(getattr(budgets, name) >= 1 for name in Budgets.names())
    assert {Budgets.unit(name) for name in Budgets.names()} == {"bytes", "frames", "clients", "recordings", "seconds"}
    assert HostSettings().budgets == budgets


def test_a_bound_on_one_thing_names_its_flag() -> None:
    budgets = Budgets(port_bytes=32 * MIB)
    budgets.check("port_bytes", "a port", 32 * MIB)
    with pytest.raises(OverBudget) as refused:
        budgets.check("port_bytes", "a port of 400 chunks of 19200 frames", 400 * 19200 * 8)
    assert str(refused.value) == ("a port of 400 chunks of 19200 frames needs 58.6 MiB, more than the 32 MiB of "
                                  "--max-port-bytes")
    assert refused.value.flag == "--max-port-bytes"


@pytest.mark.parametrize("bounds", [{"port_bytes": 0}, {"socket_clients": -1}, {"block_frames": True},
                                    {"world_bytes": 1.5}])
def test_bounds_that_cannot_hold_are_refused(bounds: dict[str, Any]) -> None:
    with pytest.raises(ValueError, match="--max-"):
        Budgets(**bounds)


def test_a_ledger_refuses_what_does_not_fit_and_gives_back_what_is_released() -> None:
    ledger = Ledger("audio_bytes", 100, "--max-audio-bytes")
    first = ledger.reserve(60, "capture", "a port")
    with pytest.raises(OverBudget, match="a port needs 50 bytes, and 60 bytes of the 100 bytes of --max-audio-bytes"):
        ledger.reserve(50, "bass", "a port")
    assert ledger.held == 60
    first.release()
    first.release()  # idempotent
    with ledger.reserve(100, "bass", "a port"):
        assert ledger.held == 100
    assert ledger.held == 0


def test_a_reservation_grows_only_when_it_fits_and_always_shrinks() -> None:
    ledger = Ledger("audio_bytes", 100, "--max-audio-bytes")
    other = ledger.reserve(30, "bass", "a port")
    mine = ledger.reserve(50, "capture", "a port")
    with pytest.raises(OverBudget):
        mine.resize(80, "a bigger port")
    assert (mine.amount, ledger.held) == (50, 80)
    mine.resize(10, "")
    assert ledger.held == 40
    other.release()
    mine.resize(100, "the biggest port")
    assert ledger.held == 100


def test_the_oldest_evictable_reservations_make_room_for_a_new_one() -> None:
    ledger = Ledger("socket_bytes", 100, "--max-socket-bytes")
    evicted: list[str] = []
    fixed = ledger.reserve(20, "fixed", "a port")
    for name in ("a", "b", "c"):
        ledger.reserve(25, name, "a reply", evict=lambda name=name: evicted.append(name))
    assert ledger.held == 95
    ledger.reserve(40, "d", "a reply", evict=lambda: evicted.append("d"))
    assert evicted == ["a", "b"]                   # oldest first, no more than needed
    assert ledger.held == 20 + 25 + 40 and ledger.evictions == 2
    assert [holder for holder, _ in ledger.holders()] == ["fixed", "c", "d"]
    fixed.release()
    with pytest.raises(OverBudget):                 # larger than the bound itself: nothing is evicted for it
        ledger.reserve(101, "e", "a reply")
    assert evicted == ["a", "b"]


def test_a_reservation_that_makes_progress_is_evicted_after_those_that_do_not() -> None:
    # A client reading a large reply slowly, asked before clients that never read, is not the one dropped.
    ledger = Ledger("socket_bytes", 100, "--max-socket-bytes")
    evicted: list[str] = []
    slow_reader = ledger.reserve(40, "reader", "a reply", evict=lambda: evicted.append("reader"))
    for name in ("stuck1", "stuck2"):
        ledger.reserve(25, name, "a reply", evict=lambda name=name: evicted.append(name))
    slow_reader.progressed()
    ledger.reserve(30, "new", "a reply", evict=lambda: evicted.append("new"))
    assert evicted == ["stuck1"]
    ledger.reserve(30, "newer", "a reply", evict=lambda: evicted.append("newer"))
    assert evicted == ["stuck1", "stuck2"]          # the reader's progress came after stuck2 was asked


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_a_kind_of_line_is_written_a_few_times_a_period_then_counted(caplog: pytest.LogCaptureFixture) -> None:
    clock = _Clock()
    log = ThrottledLog(logging.getLogger("test.throttled"), burst=3, period=60.0, clock=clock)
    with caplog.at_level(logging.INFO, "test.throttled"):
        written = [log.warning("client %d refused", n) for n in range(1000)]
        log.info("another kind")
        clock.now += 20.0                           # a third of the period: one line's worth
        log.warning("client %d refused", 1000)
    assert written.count(True) == 3
    messages = [r.getMessage() for r in caplog.records]
    assert messages == ["client 0 refused", "client 1 refused", "client 2 refused", "another kind",
                        "client 1000 refused (997 more like this left out of the log)"]


def _fail_elsewhere() -> None:
    raise KeyError("another fault")


def test_a_new_fault_s_first_traceback_is_written_however_busy_its_template(
        caplog: pytest.LogCaptureFixture) -> None:
    # Every 500 of the gateway shares one template: a client's loop of one fault must not hide another.
    log = ThrottledLog(logging.getLogger("test.new_fault"), burst=2, period=60.0, clock=_Clock())
    with caplog.at_level(logging.ERROR, "test.new_fault"):
        for n in range(10):
            try:
                _fail(n)
            except ValueError as exc:
                log.error("request failed: %s", exc, exc=exc)
        try:
            _fail_elsewhere()
        except KeyError as exc:
            assert log.error("request failed: %s", exc, exc=exc)
    traced = [r for r in caplog.records if r.exc_info is not None]
    assert [r.exc_info[0] for r in traced] == [ValueError, KeyError]
    assert len(caplog.records) == 3  # the first fault twice (its bucket), then the new one


def _fail(n: int) -> None:
    raise ValueError(f"fault {n}")


def test_a_traceback_is_written_once_per_place(caplog: pytest.LogCaptureFixture) -> None:
    log = ThrottledLog(logging.getLogger("test.traced"), burst=100)
    with caplog.at_level(logging.ERROR, "test.traced"):
        for n in range(5):
            try:
                _fail(n)
            except ValueError as exc:
                log.error("service failed: %s", exc, exc=exc)
    assert len(caplog.records) == 5
    assert caplog.records[0].exc_info is not None and not any(r.exc_info for r in caplog.records[1:])


# -- withdrawn data, and abort_activity of an unknown id ------------------------------------------

@idl_struct("sensor::frame")
class Frame:
    seq: Long = 0


class DOWN(GenomException):
    """The sensor is down."""

    scope = "sensor"
    what: String


class Sensor(Component, name="sensor"):
    Frames = OutPort(Frame, doc="frames")

    @activity
    async def Watch(self) -> None:
        """Watch until aborted."""
        await asyncio.get_running_loop().create_future()


class Reader(Component, name="reader"):
    Frames = InPort(Frame, doc="connect to sensor/Frames")

    @function
    def Latest(self) -> Annotated[Long, Out("seq", "its sequence number")]:
        """The sequence number of the latest frame."""
        frame = self.Frames.read()
        return frame.seq if frame is not None else -1


@pytest.fixture
async def host() -> Any:
    async with ComponentHost(factories={"sensor": Sensor, "reader": Reader}) as host:
        yield host


async def test_withdrawn_data_is_refused_until_the_next_publication(host: ComponentHost) -> None:
    sensor, reader = await host.load("sensor"), await host.load("reader")
    await reader.send("connect_port", {"local": "Frames", "remote": "sensor/Frames"})
    sensor.Frames.publish(Frame(1))
    sensor.Frames.withdraw(DOWN(what="the camera process died"))
    with pytest.raises(PortUnavailable) as refused:
        sensor.Frames.read()
    assert refused.value.reason.detail == {"what": "the camera process died"}
    # A service reading it through an in port ends with the sensor's reason, not an unexpected error.
    request = await reader.send("Latest")
    await request.ended.wait()
    assert request.exception == {"ex": "::sensor::DOWN", "detail": {"what": "the camera process died"}}
    sensor.Frames.publish(Frame(2))
    request = await reader.send("Latest")
    await request.ended.wait()
    assert request.output == {"seq": 2}


async def test_abort_activity_of_an_unknown_id_is_no_such_activity(host: ComponentHost,
                                                                    caplog: pytest.LogCaptureFixture) -> None:
    sensor = await host.load("sensor")
    with caplog.at_level(logging.ERROR):
        request = await sensor.send("abort_activity", {"activity": 4294967295})
        await request.ended.wait()
    assert request.exception == {"ex": "::genom::no_such_activity"}
    # The number of a function's request (its own here: the smallest free number) names no activity.
    itself = await sensor.send("abort_activity", {"activity": request.number + 1})
    await itself.ended.wait()
    assert itself.number == request.number + 1 and itself.exception == {"ex": "::genom::no_such_activity"}
    assert not caplog.records
    activity = await sensor.send("Watch")
    aborted = await sensor.send("abort_activity", {"activity": activity.number})
    await aborted.ended.wait()
    assert aborted.status == "done" and activity.exception == {"ex": "::genom::interrupted",
                                                                "detail": {"by": "abort_activity"}}
    ended = await sensor.send("abort_activity", {"activity": activity.number})  # an ended one: nothing to do
    await ended.ended.wait()
    assert ended.status == "done"
