"""The typed declaration API at run time: annotations, redeclared services, ports and their waits."""

from __future__ import annotations

import asyncio
import dataclasses
from typing import Annotated, Any

import numpy as np
import pytest
from numpy.typing import NDArray

from aiogenomix.components.core import (
    Bound, Component, ComponentHost, Double, Float, InPort, Length, Long, ManualClock, Out, OutPort, String, activity,
    array, function, idl_struct, redeclare, sequence, string,
)
from aiogenomix.components.core.runtime import InputError, idl_type


@pytest.mark.parametrize(("annotation", "spelled_before"), [
    (Annotated[str, Bound(64)], string(64)),
    (Annotated[list[String], Bound(2)], sequence(String, 2)),
    (Annotated[String, Bound(64)], string(64)),
    (list[Double], sequence(Double)),
    (Annotated[list[Double], Bound(16)], sequence(Double, 16)),
    (NDArray[np.int32], sequence(Long, numpy=True)),
    (Annotated[NDArray[np.float64], Bound(8)], sequence(Double, 8, numpy=True)),
    (Annotated[list[Long], Length(3)], array(Long, 3)),
    (Annotated[NDArray[np.float32], Length(2)], array(Float, 2, numpy=True)),
])
def test_typed_annotations_are_the_idl_types_of_the_calls(annotation: Any, spelled_before: Any) -> None:
    typed, before = idl_type(annotation), idl_type(spelled_before)
    assert typed.describe() == before.describe()
    # The same carrier too: lists, or numpy arrays of the same dtype.
    made, expected = typed.zero(), before.zero()
    assert type(made) is type(expected) and getattr(made, "dtype", None) == getattr(expected, "dtype", None)


@pytest.mark.parametrize(("annotation", "words"), [
    (Annotated[int, Bound(4)], "Bound(4) applies to strings and sequences"),
    (Annotated[str, Length(4)], "Length(4) applies to list"),
    (NDArray[np.complex128], "use NDArray[T] with T one of"),
])
def test_annotations_without_idl_meaning_are_refused(annotation: Any, words: str) -> None:
    with pytest.raises(TypeError, match=words.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        idl_type(annotation)


def test_a_port_of_no_idl_type_is_refused_with_its_class() -> None:
    with pytest.raises(TypeError, match=r"'rover'.*port Where.*has no IDL type"):
        class Rover(Component, name="rover"):
            Where = OutPort(complex, doc="Not an IDL type")


def test_a_parameter_of_no_idl_type_is_refused_with_its_class_and_service() -> None:
    with pytest.raises(TypeError, match=r"'rover' \(Rover\), service Aim: parameter 'angle': .*has no IDL type"):
        class Rover(Component, name="rover"):
            @function
            def Aim(self, angle: complex) -> None:
                """Aim."""


def test_a_return_annotation_of_no_idl_meaning_is_refused_with_its_class_and_service() -> None:
    with pytest.raises(TypeError, match=r"component 'rover' \(Rover\), service Where: return annotation .*use None"):
        class Rover(Component, name="rover"):
            @function
            def Where(self) -> complex:
                """Where."""
                return 0j


def test_an_unannotated_parameter_is_refused_with_its_class_and_service() -> None:
    with pytest.raises(TypeError, match=r"component 'rover' \(Rover\), service Go: parameter 'x' needs a type"):
        class Rover(Component, name="rover"):
            @function
            def Go(self, x) -> None:  # type: ignore[no-untyped-def]
                """Go."""


@idl_struct("rover::pose")
class Pose:
    x: Double = 0.0
    names: list[String] = dataclasses.field(default_factory=list)


class Rover(Component, name="rover"):
    """A rover."""

    Where = OutPort(Pose, doc="Where it is")
    Goal = InPort(Pose, doc="Where it goes")

    def _check(self, x: float, label: str = "") -> None:
        pass

    @activity(interrupts=("Stop",), validate=_check)
    async def Goto(self, x: Annotated[Double, "Abscissa in m"],
                   label: Annotated[str, Bound(8)] = "") -> Annotated[Pose, Out("where")]:
        """Go to x."""
        self.Where.publish(Pose(x, [label]))
        return self.Where.read()

    @function
    def Stop(self) -> None:
        """Stop."""


class LoggingRover(Rover, name="logging_rover"):
    """A rover that counts its trips."""

    trips = 0

    @redeclare(Rover.Goto, doc="Go to x and count the trip")
    async def Goto(self, **inputs: Any) -> Pose:
        type(self).trips += 1
        return await Rover.Goto(self, **inputs)


def test_a_redeclared_service_keeps_the_declaration_but_what_it_changes() -> None:
    original, redeclared = Rover.services()["Goto"], LoggingRover.services()["Goto"]
    assert redeclared.doc == "Go to x and count the trip"
    assert redeclared.describe() == {**original.describe(), "doc": "Go to x and count the trip"}
    assert (redeclared.kind, redeclared.interrupts, redeclared.validate) == ("activity", ("Stop",), Rover._check)
    assert redeclared.func is LoggingRover.Goto and redeclared.is_async
    assert list(LoggingRover.services()).count("Goto") == 1


def test_a_redeclared_method_that_does_not_take_the_inputs_is_refused() -> None:
    with pytest.raises(TypeError, match=r"'lazy'.*Goto.*redeclared method.*does not take the input 'label'"):
        class Lazy(Rover, name="lazy"):
            @redeclare(Rover.Goto)
            async def Goto(self, x: float) -> Pose:
                return Pose(x)


def test_only_a_service_can_be_redeclared() -> None:
    with pytest.raises(TypeError, match="declares no service"):
        redeclare(Rover._check)


@pytest.fixture
async def host() -> Any:
    async with ComponentHost(clock=ManualClock(), factories={"rover": LoggingRover, "other": Rover},
                             function_grace=0.01) as host:
        yield host


async def test_a_redeclared_service_runs_the_new_method(host: ComponentHost) -> None:
    rover = await host.load("rover")
    before = LoggingRover.trips
    request = await rover.send("Goto", {"x": 2.0, "label": "home"})
    await asyncio.wait_for(request.ended.wait(), 5)
    assert request.status == "done" and LoggingRover.trips == before + 1
    assert request.output == {"where": {"x": 2.0, "names": ["home"]}}
    with pytest.raises(InputError, match="bound of 8"):  # the inputs of the original, decoded as declared
        await rover.send("Goto", {"x": 1.0, "label": "far too long"})
    assert LoggingRover.trips == before + 1


async def test_an_in_port_waits_for_its_connection_then_for_a_publication(host: ComponentHost) -> None:
    rover, other = await host.load("rover"), await host.load("other")
    waiting = asyncio.create_task(rover.Goal.wait_published())
    await asyncio.sleep(0)
    assert not waiting.done()  # no connection yet
    connected = await rover.send("connect_port", {"local": "Goal", "remote": "other/Where"})
    assert connected.status == "done"
    await asyncio.sleep(0)
    assert not waiting.done()  # connected: waits for the next publication
    other.Where.publish(Pose(4.0))
    assert await asyncio.wait_for(waiting, 5) == other.Where.version
    assert rover.Goal.read() == Pose(4.0)
