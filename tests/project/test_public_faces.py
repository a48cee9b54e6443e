"""The public faces: what a component author imports, what a host imports, what kemar shows."""

from __future__ import annotations

import ast
import pathlib
import pydoc
import re
import tomllib
import types

import pytest

from aiogenomix.components import core, kemar
from aiogenomix.components.core import runtime

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("face", [core, runtime])
def test_public_names_say_where_they_are_imported_from(face: object) -> None:
    for name in face.__all__:  # type: ignore[attr-defined]
        obj = getattr(face, name)
        module = getattr(obj, "__module__", None)
        if isinstance(obj, type) or callable(obj) and module and module.startswith("aiogenomix."):
            assert module == face.__name__, name  # type: ignore[attr-defined]


def test_help_shows_the_public_paths() -> None:
    text = pydoc.render_doc(core.OutPort, renderer=pydoc.plaintext)
    assert "class OutPort in module aiogenomix.components.core\n" in text
    package = pydoc.render_doc(core, renderer=pydoc.plaintext)
    # Only the private base of the port runtimes is named by its private module.
    named = re.findall(r"aiogenomix\.components\.core\._\w+\.(\w+)", package)
    assert all(name.startswith("_PortRunti") for name in named)  # pydoc cuts long names short


def test_the_author_face_and_the_runtime_are_apart() -> None:
    assert not set(core.__all__) & set(runtime.__all__)
    assert {"Component", "OutPort", "InPort", "function", "activity", "attribute", "redeclare", "idl_struct",
            "Bound", "Length", "GenomException"} <= set(core.__all__)
    assert {"RequestTracker", "ServiceSpec", "IdlType", "describe"} <= set(runtime.__all__)


#: Runtime names the gateway's modules held by the HTTP rewrite (issue 20) still import from core;
#: they leave the author's face when those modules import them from core.runtime.
@pytest.mark.parametrize("face", [core, runtime])
def test_a_face_exports_what_its_all_says(face: types.ModuleType) -> None:
    public = {name for name, value in vars(face).items()
              if not name.startswith("_") and not isinstance(value, types.ModuleType)}
    assert public == set(face.__all__)


def _imports_from_core(path: pathlib.Path) -> list[str]:
    """The names *path* imports from ``aiogenomix.components.core`` itself (absolutely or relatively)."""
    names = []
    package = ["aiogenomix", *path.relative_to(ROOT).parent.parts]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = package[:len(package) - node.level + 1]
            module = ".".join([*base, *(node.module or "").split(".")]).strip(".")
        else:
            module = node.module or ""
        if module == "aiogenomix.components.core":
            names += [alias.name for alias in node.names]
    return names


def test_no_module_of_ours_imports_a_runtime_name_from_the_authors_face() -> None:
    sources = [p for folder in ("components", "gateway", "clients", "tests", "bench", "examples")
               for p in (ROOT / folder).rglob("*.py")]
    outside = [f"{path.relative_to(ROOT)}: {name}" for path in sources for name in _imports_from_core(path)
               if name not in core.__all__ and not isinstance(getattr(core, name, None), types.ModuleType)]
    assert outside == []


def test_kemar_shows_its_component_driver_and_simulated_drive_not_its_codec() -> None:
    assert {"Kemar", "HarmonicaDriver", "SimulatedHarmonica", "KemarHead", "MotorFault"} <= set(kemar.__all__)
    for private in ("encode_set", "decode_reply", "CobIds", "InterpreterRequest", "plan_move", "Trajectory"):
        assert not hasattr(kemar, private), private


def test_the_layer_contracts_name_every_private_module_of_the_core() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    contract = next(c for c in config["tool"]["importlinter"]["contracts"] if "private modules" in c["name"])
    private = {f"aiogenomix.components.core.{p.stem}" for p in (ROOT / "components" / "core").glob("_*.py")
               if p.stem != "__init__"}
    assert set(contract["forbidden_modules"]) == private
