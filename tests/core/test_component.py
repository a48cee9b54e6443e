"""The request engine of a component: outcomes, interruption, ids, outputs, defaults, tasks and ports."""

from __future__ import annotations

import asyncio
import dataclasses
import logging
from typing import Annotated, Any

import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Double, GenomException, HostSettings, InPort, ManualClock, Out, OutPort, RequestEvent,
    Short, String, Task, activity, attribute, function, idl_struct, port_io,
)
from aiogenomix.components.core.runtime import (
    InputError, NoSuchModule, NoSuchPort, NoSuchRequest, RequestRunning, describe,
)


class TOO_BIG(GenomException):
    """The value is too big."""

    limit: Double


@idl_struct("gadget::reading")
class Reading:
    value: Double = 0.0


@dataclasses.dataclass
class Pair:
    low: Annotated[Short, "The lower one"]
    high: Annotated[Short, "The higher one"]


@dataclasses.dataclass(frozen=True)
class GadgetSettings:
    """The settings of the gadget, one default each: given to a host in HostSettings(extra=...)."""

    default_amount: float = 1.0


class Gadget(Component, name="gadget", version="2.0"):
    """A component for testing the runtime."""

    loop = Task(period=1.0, doc="Counts periods")
    Level = OutPort(Reading, doc="The level")
    Named = OutPort(Reading, doc="Named readings", multiple=True)
    Input = InPort(Reading, doc="A connected reading")

    async def on_start(self) -> None:
        self.stopped_paths: list[str] = []
        self.periods = 0

    @loop.periodic
    def _count(self) -> None:
        self.periods += 1

    async def _check(self, amount: float) -> None:
        if amount > 10:
            raise TOO_BIG(limit=10.0)

    @activity(task=loop, interrupts=("Fill",), throws=(TOO_BIG,), validate=_check)
    async def Fill(self, amount: Annotated[Double, "How much"] = 1.0) -> None:
        """Fill slowly."""
        try:
            await self.clock.sleep(amount)
            self.Level.publish(Reading(amount))
        finally:
            self.stopped_paths.append("Fill")

    @activity
    async def Fail(self, how: Annotated[String, "declared or unexpected"] = "declared") -> None:
        """Fail on purpose."""
        if how == "declared":
            raise TOO_BIG(limit=1.5)
        raise RuntimeError("boom")

    @activity
    async def Hold(self) -> None:
        """Run until interrupted."""
        await asyncio.Event().wait()

    @function(interrupts=("Fill",))
    def Drain(self) -> None:
        """Stop filling."""

    @function
    def Split(self, total: Short = 4) -> Pair:
        """Two outputs."""
        return Pair(total // 2 - 1, total // 2 + 1)

    @attribute
    def GetName(self) -> Annotated[String, Out("name", "Its name")]:
        """One output."""
        return self.instance

    @function
    async def Slow(self) -> None:
        """A function slower than the send grace (its time passes when the test advances the clock)."""
        await self.clock.sleep(1.0)

    @classmethod
    def service_defaults(cls, host: ComponentHost) -> dict[str, dict[str, Any]]:
        return {"Fill": {"amount": host.settings.of(GadgetSettings).default_amount}}


@pytest.fixture
async def host() -> Any:
    events: list[dict[str, Any]] = []
    settings = HostSettings(extra=(GadgetSettings(default_amount=2.0),))
    async with ComponentHost(clock=ManualClock(), settings=settings,
                             factories={"gadget": Gadget}, function_grace=0.01) as host:
        # What a session's listeners would hear: the request events the host publishes, as data.
        host.events.subscribe(lambda event: events.append(event.data()) if isinstance(event, RequestEvent) else None)
        host.statuses = events  # type: ignore[attr-defined]
        yield host


async def test_description_is_in_declaration_order(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    info = describe(gadget)
    names = [s["name"] for s in info["services"]]
    assert names == ["Fill", "Fail", "Hold", "Drain", "Split", "GetName", "Slow",
                     "abort_activity", "connect_port", "connect_service", "kill"]
    fill = info["services"][0]
    assert fill["parameters"] == [{"name": "amount", "dir": "in", "type": {"name": "double", "kind": "double"},
                                   "doc": "How much", "default": 2.0}]  # the host-dependent default
    assert fill["throws"] == ["::gadget::TOO_BIG"] and fill["interrupts"] == ["Fill"]
    split = next(s for s in info["services"] if s["name"] == "Split")
    assert [(p["name"], p["dir"]) for p in split["parameters"]] == [("total", "in"), ("low", "out"), ("high", "out")]
    assert [p["name"] for p in info["ports"]] == ["Level", "Named", "Input", "genom_state"]
    assert info["exceptions"][0] == {"name": "::gadget::TOO_BIG", "doc": "The value is too big.",
                                     "detail": [{"name": "limit", "type": {"name": "double", "kind": "double"}}]}
    # The standard exceptions of the standard services are declared too.
    assert {"::genom::no_such_inport", "::genom::no_such_outport"} <= {e["name"] for e in info["exceptions"]}
    assert info["tasks"] == [{"name": "loop", "period": 1.0, "doc": "Counts periods"}]


async def test_interruption_runs_the_stop_path_and_names_the_interrupter(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    first = await gadget.send("Fill", {"amount": 5}, session="s")
    await host.clock.advance(0.5)  # type: ignore[attr-defined]  # Fill is under way: it has a stop path to run
    second = await gadget.send("Fill", {"amount": 1}, session="s")
    assert first.status_object() == {"id": "gadget::0", "status": "error",
                                      "exception": {"ex": "::genom::interrupted", "detail": {"by": "Fill"}}}
    assert gadget.stopped_paths == ["Fill"]
    drain = await gadget.send("Drain")
    assert drain.status == "done"
    assert second.exception == {"ex": "::genom::interrupted", "detail": {"by": "Drain"}}
    assert gadget.stopped_paths == ["Fill", "Fill"]
    assert [e["status"] for e in host.statuses if e["id"] == "gadget::0"] == ["sent", "error"]


async def test_abort_and_ids_reused_after_clean(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    running = await gadget.send("Fill", {"amount": 5})
    with pytest.raises(RequestRunning):
        gadget.requests.clean("gadget::0")
    aborted = await gadget.abort("0")
    assert aborted.exception == {"ex": "::genom::interrupted", "detail": {"by": "abort"}}
    assert (await gadget.send("GetName")).id == "gadget::1"
    gadget.requests.clean("::gadget::0")
    assert (await gadget.send("GetName")).id == "gadget::0"
    with pytest.raises(NoSuchRequest):
        gadget.requests.get("gadget::7")
    assert running.status == "error"


async def test_outputs_single_and_several(host: ComponentHost) -> None:
    gadget = await host.load("gadget", ["-i", "g2"])
    assert (await gadget.send("GetName")).output == {"name": "g2"}
    assert (await gadget.send("Split", {"total": 10})).output == {"low": 4, "high": 6}


async def test_exceptions_declared_and_unexpected(host: ComponentHost, caplog: pytest.LogCaptureFixture) -> None:
    gadget = await host.load("gadget")
    declared = await gadget.send("Fail")
    await declared.ended.wait()
    assert declared.exception == {"ex": "::gadget::TOO_BIG", "detail": {"limit": 1.5}}
    with caplog.at_level(logging.ERROR):
        unexpected = await gadget.send("Fail", {"how": "other"})
        await unexpected.ended.wait()
    assert unexpected.exception == {"ex": "::genom::unkex", "detail": {"what": "RuntimeError: boom"}}
    assert "boom" in caplog.text  # reported, not swallowed


async def test_validate_refusal_ends_the_request_in_error(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    filling = await gadget.send("Fill", {"amount": 5}, session="s")
    refused = await gadget.send("Fill", {"amount": 11}, session="s")
    # As in genom3: the request exists, ends in error with the declared exception, and is reported once.
    assert refused.status_object() == {"id": "gadget::1", "status": "error",
                                        "exception": {"ex": "::gadget::TOO_BIG", "detail": {"limit": 10.0}}}
    assert [e for e in host.statuses if e["id"] == "gadget::1"] == [refused.status_object()]
    # A refused request interrupts nothing: Fill goes on.
    assert filling.running and gadget.requests.running() == [filling]
    # Input that does not fit its type is refused before anything is sent: no request.
    with pytest.raises(InputError):
        await gadget.send("Fill", {"amount": "lots"})
    assert gadget.requests.running() == [filling]
    await host.clock.advance(5)  # type: ignore[attr-defined]
    assert filling.status == "done"


async def test_oneway_requests_leave_no_trace(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    request = await gadget.send("GetName", oneway=True)
    assert request.status == "done"
    assert host.statuses == []
    with pytest.raises(NoSuchRequest):
        gadget.requests.get(request.number)


async def test_slow_function_replies_sent_then_ends(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    request = await gadget.send("Slow", session="s")
    assert request.status == "sent"
    await host.clock.advance(1.0)  # type: ignore[attr-defined]
    await request.ended.wait()
    assert [e["status"] for e in host.statuses] == ["sent", "done"]


async def test_kill_interrupts_and_unloads(host: ComponentHost) -> None:
    unloaded = asyncio.Event()
    host.add_unload_listener(lambda name: unloaded.set())
    gadget = await host.load("gadget")
    filling = await gadget.send("Fill", {"amount": 9})
    await gadget.send("kill")
    await unloaded.wait()
    assert filling.exception == {"ex": "::genom::interrupted", "detail": {"by": "kill"}}
    assert "gadget" not in host.instances


async def test_periodic_task_and_state_port(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    clock = host.clock
    assert isinstance(clock, ManualClock)
    await clock.advance(3.5)
    assert gadget.periods == 3
    await gadget.send("Fill", {"amount": 5})
    state = gadget.genom_state.encoded()
    assert state["task"][0]["name"] == "loop"
    assert state["task"][0]["rusage"]["cycles"] == 3
    assert state["task"][0]["activity"] == [{"id": 0, "name": "Fill"}]


async def test_ports_publish_wait_and_elements(host: ComponentHost) -> None:
    gadget = await host.load("gadget")
    waiter = asyncio.create_task(gadget.Level.wait_published(after_version=0))
    gadget.Level.publish(Reading(3.0))
    assert await waiter == 1
    assert gadget.Level.encoded() == {"value": 3.0}
    gadget.Named.publish(Reading(1.0), name="left")
    assert gadget.Named.encoded("left") == {"value": 1.0}
    with pytest.raises(NoSuchPort, match="no element 'right'"):
        gadget.Named.read("right")
    with pytest.raises(port_io, match="name an element"):
        gadget.Named.read()
    assert gadget.Input.read() is None
    # An out port of another type is refused, both types named: the reader would take one struct for another.
    refused = await gadget.send("connect_port", {"local": "Input", "remote": "gadget/genom_state"})
    state_type = gadget.genom_state.type.name
    assert refused.exception == {"ex": "::genom::port_io", "detail": {
        "what": f"gadget/Input reads ::gadget::reading, gadget/genom_state publishes {state_type}"}}
    assert gadget.Input.read() is None
    connected = await gadget.send("connect_port", {"local": "Input", "remote": "gadget/Level"})
    assert connected.status == "done"
    assert gadget.Input.read() == Reading(3.0)


async def test_too_many_activities(host: ComponentHost, monkeypatch: pytest.MonkeyPatch) -> None:
    from aiogenomix.components.core import too_many_activities

    monkeypatch.setattr(Gadget, "max_activities", 2)
    gadget = await host.load("gadget")
    await gadget.send("Hold")
    await gadget.send("Hold")
    with pytest.raises(too_many_activities):
        await gadget.send("Hold")
    assert (await gadget.send("GetName")).status == "done"  # functions are not limited


async def test_an_unknown_instance_is_refused_naming_the_likely_ones_not_every_loaded_one(host: ComponentHost) -> None:
    for name in ("gadget", "gadget2"):
        await host.load("gadget", ["-i", name])
    with pytest.raises(NoSuchModule, match=r"^no module 'gadgte' is loaded \(loaded: gadget, gadget2\)$"):
        host.get("gadgte")
    # Forty remote instances are not repeated in every refusal: the close ones are, and where the rest are.
    for number in range(3, 41):
        await host.load("gadget", ["-i", f"gadget{number}"])
    with pytest.raises(NoSuchModule) as refused:
        host.get("gadget400")
    assert str(refused.value) == ("no module 'gadget400' is loaded (did you mean gadget40 or gadget4 or gadget34? "
                                  "40 loaded, listed by /)")
    with pytest.raises(NoSuchModule, match=r"^no module 'robot' is loaded \(40 loaded, listed by /\)$"):
        host.get("robot")


def test_a_port_known_only_by_its_description_has_a_public_declaration() -> None:
    """What the replay and the remote mirror build: a port whose type is its description's, data passed as it is."""
    described = {"name": "Pose", "dir": "out", "kind": "simple", "doc": "Where the robot is",
                 "type": {"name": "::far::pose", "kind": "struct", "members": [
                     {"name": "x", "type": {"name": "double", "kind": "double"}}]}}
    port = OutPort.from_description(described, "recorded")
    assert port.describe() == described and port.name == "Pose"
    assert port.type.kind == "recorded" and port.type.zero() is None   # nothing until the first publication
    runtime = port.runtime(object())
    runtime.publish({"x": 1.5})
    assert runtime.read() == {"x": 1.5} and runtime.version == 1
    several = OutPort.from_description({"name": "Poses", "kind": "multiple", "type": described["type"]}, "mirrored")
    assert several.multiple and several.describe()["kind"] == "multiple" and several.doc == ""
