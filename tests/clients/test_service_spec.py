"""Signatures, docstrings and argument binding built from an /info description, without a gateway."""

from __future__ import annotations

import inspect
from typing import Any

import pytest
from aiogenomix.clients import USE_CLIENT_DEFAULT, Record
from aiogenomix.clients._module import ModuleDescription
from aiogenomix.clients._service import ServiceSpec

DOUBLE = {"name": "double", "kind": "double"}
LONG = {"name": "long", "kind": "long"}


def param(name: str, t: dict[str, Any], direction: str = "in", **extra: Any) -> dict[str, Any]:
    return {"name": name, "dir": direction, "type": t, "doc": f"the {name}", **extra}


INFO: dict[str, Any] = {
    "name": "odd2", "component": "odd", "version": "0.1", "doc": "A component with awkward names.", "revision": 1,
    "services": [
        {"name": "Shape", "kind": "function", "doc": "Set a shape.", "task": None,
         "parameters": [param("width", LONG), param("height", LONG, default=2), param("depth", LONG),
                        param("area", LONG, "out"), param("volume", DOUBLE, "out")],
         "interrupts": [], "throws": ["::odd::BAD"]},
        {"name": "Wait", "kind": "activity", "doc": "", "task": "main",
         "parameters": [param("timeout", DOUBLE, default=1.5), param("class", LONG, default=0),
                        param("left", DOUBLE, "inout", default=0.0)],
         "interrupts": ["Wait"], "throws": []},
    ],
    "ports": [{"name": "Cams", "dir": "out", "kind": "multiple", "type": DOUBLE, "doc": "Cameras."}],
    "exceptions": [{"name": "::odd::BAD", "doc": "Bad shape.", "detail": [{"name": "why", "type": LONG}]}],
    "tasks": [],
}


def spec(name: str) -> ServiceSpec:
    return ModuleDescription(INFO).services[name]  # type: ignore[arg-type]


def test_signature_keeps_declaration_order_and_defaults() -> None:
    signature = spec("Shape").signature
    params = list(signature.parameters.values())
    assert [p.name for p in params] == ["width", "height", "depth", "ack", "callback", "oneway", "timeout"]
    assert params[0].default is inspect.Parameter.empty
    assert params[1].default == 2 and params[1].annotation is int
    assert repr(params[2].default) == "<zero of its type>"     # no /info default after one with a default
    assert params[-1].default is USE_CLIENT_DEFAULT
    assert signature.return_annotation is Record                # several outputs


def test_names_that_clash_with_python_or_options() -> None:
    s = spec("Wait")
    names = list(s.signature.parameters)
    assert names == ["timeout", "class_", "left", "ack", "callback", "oneway", "timeout_"]
    inputs, options = s.bind((), {"timeout": 3, "class_": 2, "timeout_": 0.5})
    assert inputs == {"timeout": 3.0, "class": 2} and options.timeout == 0.5
    inputs, _ = s.bind(({"class": 4},), {})                   # one dict, by wire names
    assert inputs == {"class": 4}
    assert s.signature.return_annotation is float               # the inout parameter is the one output


def test_binding_forms_and_errors() -> None:
    s = spec("Shape")
    assert s.bind((3,), {})[0] == {"width": 3}                  # left out: not sent, the component fills in
    assert s.bind((3, 4, 5), {"ack": True})[0] == {"width": 3, "height": 4, "depth": 5}
    assert s.bind(({"width": 1, "depth": 2},), {})[0] == {"width": 1, "depth": 2}
    with pytest.raises(TypeError, match=r"Shape\(width"):
        s.bind((), {})
    with pytest.raises(TypeError, match="too many"):
        s.bind((1, 2, 3, 4), {})
    assert s.result(s.decode_outputs({"area": 6, "volume": 7})) == {"area": 6, "volume": 7.0}


def test_docstring_and_module_doc() -> None:
    doc = spec("Shape").doc
    assert doc.startswith("Set a shape.")
    for text in ("width (long): the width. Default: the zero of its type.", "height (long): the height. Default: 2.",
                 "Returns:", "area (long)", "BAD: ::odd::BAD. Bad shape. Detail: why (long).", "Raises:"):
        assert text in doc
    assert "Interrupted: when interrupted; ``by`` names who (abort)" in doc
    description = ModuleDescription(INFO)  # type: ignore[arg-type]
    assert "Instance odd2 of component odd 0.1." in description.doc()
    cams = description.ports["Cams"]
    assert list(cams.signature.parameters) == ["name", "since", "raw", "timeout"]
    assert description.exceptions["BAD"].__name__ == "BAD"
