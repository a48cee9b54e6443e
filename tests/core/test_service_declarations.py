"""Mistakes in service declarations are refused when the component class is created, not at a request."""

from __future__ import annotations

from typing import Annotated

import pytest

from aiogenomix.components.core import Component, Double, GenomException, activity, function


class TOO_FAST(GenomException):
    """Too fast."""


def test_a_validate_hook_missing_an_input_is_refused() -> None:
    with pytest.raises(TypeError) as refused:
        class Rover(Component, name="rover"):
            def _check(self, speed: float) -> None:
                pass

            @activity(validate=_check)
            async def Drive(self, speed: Double = 0.0, heading: Annotated[Double, "deg"] = 0.0) -> None:
                """Drive."""

    message = str(refused.value)
    assert "'rover'" in message and "Drive" in message and "'heading'" in message


def test_a_validate_hook_with_a_parameter_the_service_lacks_is_refused() -> None:
    with pytest.raises(TypeError) as refused:
        class Rover(Component, name="rover"):
            def _check(self, velocity: float) -> None:  # the service calls it speed
                pass

            @activity(validate=_check)
            async def Drive(self, speed: Double = 0.0) -> None:
                """Drive."""

    message = str(refused.value)
    assert "'rover'" in message and "Drive" in message and "'velocity'" in message


def test_a_validate_hook_without_the_component_is_refused() -> None:
    def check() -> None:
        pass

    with pytest.raises(TypeError, match=r"'rover'.*Stop.*component first"):
        class Rover(Component, name="rover"):
            @function(validate=check)
            def Stop(self) -> None:
                """Stop."""


def test_validate_hooks_that_fit_are_accepted() -> None:
    class Rover(Component, name="rover"):
        def _exact(self, speed: float) -> None:
            pass

        async def _keywords(self, **inputs: float) -> None:
            pass

        def _optional_extra(self, speed: float, strict: bool = False) -> None:
            pass

        @activity(validate=_exact, throws=(TOO_FAST,))
        async def Drive(self, speed: Double = 0.0) -> None:
            """Drive."""

        @activity(validate=_keywords)
        async def Cruise(self, speed: Double = 0.0) -> None:
            """Cruise."""

        @activity(validate=_optional_extra)
        async def Race(self, speed: Double = 0.0) -> None:
            """Race."""

    assert Rover.services()["Drive"].validate is not None


def test_a_misspelled_option_is_refused_with_a_suggestion() -> None:
    with pytest.raises(TypeError) as refused:
        class Rover(Component, name="rover"):
            @activity(interupts=("Drive",))
            async def Drive(self) -> None:
                """Drive."""

    message = str(refused.value)
    assert "Rover.Drive" in message and "'interupts'" in message and "did you mean 'interrupts'" in message


@pytest.mark.parametrize(("options", "words"), [
    ({"interrupts": "Drive"}, "'interrupts' must be a tuple"),     # a string would be read letter by letter
    ({"throws": (ValueError,)}, "'throws' takes GenomException classes"),
    ({"validate": "check"}, "'validate' must be callable"),
    ({"motion": "yes"}, "'motion' is True or False"),
])
def test_options_of_the_wrong_shape_are_refused(options: dict[str, object], words: str) -> None:
    with pytest.raises(TypeError, match="Rover.Drive") as refused:
        class Rover(Component, name="rover"):
            @activity(**options)
            async def Drive(self) -> None:
                """Drive."""

    assert words in str(refused.value)


def test_a_motion_is_an_activity_declared_so() -> None:
    class Rover(Component, name="rover"):
        @activity(motion=True)
        async def Drive(self) -> None:
            """Drive: its host stops it when the gateway that started it vanishes."""

        @activity
        async def Record(self) -> None:
            """Record: it goes on whoever vanishes."""

    assert Rover.services()["Drive"].motion and not Rover.services()["Record"].motion
    with pytest.raises(TypeError, match="only an @activity can be a motion"):
        class Arm(Component, name="arm"):
            @function(motion=True)
            def Stop(self) -> None:
                """Stop."""


def test_the_robots_motions_are_declared_so_and_nothing_else_is() -> None:
    from aiogenomix.components.bass import Bass
    from aiogenomix.components.capture import Capture
    from aiogenomix.components.demo import Demo
    from aiogenomix.components.kemar import Kemar

    def motions(component: type[Component]) -> set[str]:
        return {name for name, spec in component.services().items() if spec.motion}

    assert motions(Demo) == {"GotoPosition", "MoveDistance"}
    assert motions(Kemar) == {"Homing", "MoveAbsolutePosition", "MoveRelativePosition", "ControlInSpeed"}
    # A capture, its socket, a recording go on when their client vanishes: their data is kept for the next.
    assert motions(Capture) == motions(Bass) == set()
