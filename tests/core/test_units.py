"""Units and grids declared on members and parameters (issue 34): /info, the JSON Schemas, the client's docs."""

from __future__ import annotations

import dataclasses
from typing import Annotated

import numpy as np
import pytest
from numpy.typing import NDArray

from aiogenomix.components.core import (
    Component, Double, Grid, Out, OutPort, Unit, activity, idl_struct, json_schema,
)
from aiogenomix.components.core.runtime import idl_type


@idl_struct("units::head")
class Head:
    """A head and where it hears from."""

    azimuth: Annotated[Double, Unit("deg"), "Where it looks"] = 0.0
    speed: Annotated[Double, Unit("deg/s")] = 0.0
    plain: Double = 0.0
    likelihood: Annotated[NDArray[np.float64], Grid(0, 1, "deg"), "One per degree"] = \
        dataclasses.field(default_factory=lambda: np.zeros(0))


class Turner(Component, name="turner"):
    """Turns a head."""

    State = OutPort(Head, doc="The head")

    @activity
    async def Turn(self, target: Annotated[Double, Unit("deg"), "Where to look"] = 0.0,
                   plain: Double = 0.0) -> Annotated[Double, Unit("deg"), Out("reached", "Where it looks now")]:
        """Turn the head."""
        return target


def test_a_member_says_its_unit_and_grid_beside_its_doc() -> None:
    members = idl_type(Head).describe()["members"]
    assert members[0] == {"name": "azimuth", "type": {"name": "double", "kind": "double"}, "doc": "Where it looks",
                          "unit": "deg"}
    assert members[1] == {"name": "speed", "type": {"name": "double", "kind": "double"}, "unit": "deg/s"}
    assert members[2] == {"name": "plain", "type": {"name": "double", "kind": "double"}}   # as before: no new key
    assert members[3]["grid"] == {"start": 0, "step": 1, "unit": "deg"} and members[3]["doc"] == "One per degree"


def test_a_parameter_says_its_unit() -> None:
    spec = Turner.services()["Turn"]
    target, plain = (p.describe() for p in spec.inputs)
    assert target["unit"] == "deg" and "unit" not in plain
    (reached,) = (p.describe() for p in spec.outputs)
    assert reached["unit"] == "deg"


def test_json_schemas_carry_the_unit_as_x_unit() -> None:
    schema = json_schema(idl_type(Head).describe())
    assert schema["properties"]["azimuth"]["x-unit"] == "deg"
    assert schema["properties"]["azimuth"]["description"] == "Where it looks"
    assert "x-unit" not in schema["properties"]["plain"]


@pytest.mark.parametrize("bad", ["", "°", "deg\n"])
def test_a_unit_is_a_printable_ascii_symbol(bad: str) -> None:
    with pytest.raises(TypeError, match="printable ASCII"):
        Unit(bad)


def test_a_grid_steps_somewhere() -> None:
    with pytest.raises(TypeError, match="step is not 0"):
        Grid(0, 0, "deg")


def test_two_units_for_one_member_are_refused() -> None:
    @idl_struct("units::twice")
    class Twice:
        value: Annotated[Double, Unit("deg"), Unit("rad")] = 0.0

    with pytest.raises(TypeError, match="more than one unit"):
        idl_type(Twice).describe()
