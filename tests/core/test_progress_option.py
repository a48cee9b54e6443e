"""An activity says where its progress is published (issue 34): /info carries it, the class checks it."""

from __future__ import annotations

import pytest

from aiogenomix.components.core import Component, Double, OutPort, activity, function, idl_struct


@idl_struct("progress::state")
class State:
    position: Double = 0.0


class Mover(Component, name="mover"):
    """Moves."""

    Where = OutPort(State, doc="Where it is")

    @activity(progress="Where.position")
    async def Move(self) -> None:
        """Move."""

    @activity
    async def Wait(self) -> None:
        """Wait."""


def test_info_says_where_progress_is_published() -> None:
    services = Mover.services()
    assert services["Move"].describe()["progress"] == "Where.position"
    assert "progress" not in services["Wait"].describe()       # as before for the others


@pytest.mark.parametrize(("progress", "refusal"), [
    ("Nowhere.position", r"progress='Nowhere.position' names no out port \(out ports: Where, genom_state\)"),
    ("Where.speed", r"::progress::state has no member 'speed' \(members: position\)"),
])
def test_a_progress_that_names_nothing_is_refused_with_the_class(progress: str, refusal: str) -> None:
    with pytest.raises(TypeError, match=refusal):
        class Bad(Component, name="bad"):
            Where = OutPort(State)

            @activity(progress=progress)
            async def Move(self) -> None:
                """Move."""


def test_a_progress_is_a_dotted_name() -> None:
    with pytest.raises(TypeError, match="names an out port and a member"):
        class Bad(Component, name="bad"):
            @activity(progress="Where/position")
            async def Move(self) -> None:
                """Move."""


def test_only_an_activity_has_a_progress() -> None:
    with pytest.raises(TypeError, match="only an @activity has a progress"):
        class Bad(Component, name="bad"):
            Where = OutPort(State)

            @function(progress="Where.position")
            def Move(self) -> None:
                """Move."""
