"""JSON Schemas of ``/info`` types (the runtime's converter): port data as components write it validates.

The same converter gives the OpenAPI document its named models and a recording's (or the live view's)
JSON channels their self-contained schemas.  Also here: the
host's load listeners, which the recorder and the live view rely on.
"""

from __future__ import annotations

import math

import jsonschema
import numpy as np
import orjson
import pytest

from aiogenomix.components.core import (
    Component, ComponentHost, Double, JsonSchemas, VirtualClock, activity, function, json_schema,
)
from aiogenomix.components.kemar import KemarState
from aiogenomix.components.kemarcapture import KemarPortData
from aiogenomix.components.world import World
from aiogenomix.components.core.runtime import idl_type


def _valid(description: dict[str, object], value: object) -> None:
    schema = json_schema(description)  # type: ignore[arg-type]
    jsonschema.Draft202012Validator.check_schema(schema)
    data = orjson.loads(orjson.dumps(idl_type(type(value)).encode(value), option=orjson.OPT_SERIALIZE_NUMPY))
    jsonschema.validate(data, schema, cls=jsonschema.Draft202012Validator)


def test_port_data_validates_against_its_schema() -> None:
    state = KemarState(position=12.5, speed=math.nan, maxLeft=90.0, maxRight=-90.0)
    _valid(idl_type(KemarState).describe(), state)
    window = KemarPortData(transfer_rate=44100, nbframes=2, index=1, left=np.array([1, -2], np.int32),
                           right=np.array([3, 4], np.int32), positions=np.array([0.5]))
    _valid(idl_type(KemarPortData).describe(), window)


def test_a_schema_is_self_contained_with_its_structs_in_place() -> None:
    schema = json_schema(World.ports()["pr2_scan"].describe()["type"], title="world/pr2_scan", doc="the laser")
    assert schema["type"] == "object" and schema["title"] == "world/pr2_scan" and schema["description"] == "the laser"
    assert "$ref" not in orjson.dumps(schema).decode() and "$defs" not in schema
    assert schema["properties"]["header"]["properties"]["stamp"]["required"] == ["tv_sec", "tv_nsec"]
    assert schema["properties"]["ranges"] == {"type": "array", "items": {"type": ["number", "null"]}}
    refused = {**idl_type(KemarState).encode(KemarState()), "position": "left"}
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(refused, json_schema(idl_type(KemarState).describe()))


def test_an_api_document_names_its_structs_once() -> None:
    schemas = JsonSchemas("#/components/schemas/")
    described = idl_type(KemarState).describe()
    assert schemas.output(described) == {"$ref": "#/components/schemas/kemar_state"}
    assert schemas.input(described) == {"$ref": "#/components/schemas/kemar_state_Input"}
    assert set(schemas.named) == {"kemar_state", "kemar_state_Input", "kemar_timestamp_t", "kemar_timestamp_t_Input"}


class Rig(Component, name="rig"):
    """Declares a recording-like activity and a motion."""

    @activity
    async def Record(self) -> None:
        """Outlives whoever started it: not a motion."""

    @activity(motion=True)
    async def Move(self, speed: Double = 0.0) -> None:
        """A motion: its host stops it when the gateway that sent it is gone."""

    @function
    def Status(self) -> None:
        """Nothing."""


async def test_a_host_tells_its_load_listeners_of_each_instance_started() -> None:
    seen: list[str] = []
    async with ComponentHost(clock=VirtualClock(), factories={"rig": Rig}) as host:
        host.add_load_listener(lambda component: seen.append(component.instance))
        await host.load("rig")
        await host.load("rig")             # loaded already: no new instance
        await host.load("rig", ["-i", "second"])
    assert seen == ["rig", "second"]
