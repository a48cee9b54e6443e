"""No IDL type name is spelt outside the component that declares it: other code reads what a port carries.

What a port is (audio, a head's state, a picture) its type declares once, as its port kind; the
recording, the live view, the export and the localiser dispatch on that, for any component's port.
A type name written anywhere else (``== "::kemar::state"``, a table keyed by type names) is the
stringly coupling this replaces: it breaks for another package's port, and for a renamed type.
The product's syntax trees are searched for the string constants of every declared name.
"""

from __future__ import annotations

import ast
import pathlib
from collections.abc import Iterator

ROOT = pathlib.Path(__file__).resolve().parents[2]
PRODUCT = ("gateway", "clients", "components", "remote", "record")


def modules(root: pathlib.Path) -> Iterator[pathlib.Path]:
    for top in PRODUCT:
        yield from sorted((root / top).rglob("*.py"))


def owner(root: pathlib.Path, path: pathlib.Path) -> str:
    """The component (or top package) a module belongs to: ``components/kemar``, ``gateway``..."""
    parts = path.relative_to(root).parts
    return "/".join(parts[:2]) if parts[0] == "components" and len(parts) > 2 else parts[0]


def declared_types(root: pathlib.Path) -> dict[str, str]:
    """Every IDL name declared with ``idl_struct("...")`` or ``idl_enum("...")``, scoped, with its component."""
    names: dict[str, str] = {}
    for path in modules(root):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None))
                    in ("idl_struct", "idl_enum") and node.args and isinstance(node.args[0], ast.Constant)
                    and isinstance(node.args[0].value, str)):
                name = node.args[0].value
                names["::" + name.removeprefix("::")] = owner(root, path)
    return names


def strangers(root: pathlib.Path) -> list[str]:
    """``path:line: name`` of each string constant, outside its declaring component, that spells a declared type."""
    declared = declared_types(root)
    found = []
    for path in modules(root):
        home = owner(root, path)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Constant) and isinstance(node.value, str)):
                continue
            scoped = "::" + node.value.removeprefix("::")
            if scoped in declared and declared[scoped] != home:
                found.append(f"{path.relative_to(root)}:{node.lineno}: {node.value!r} (declared in {declared[scoped]})")
    return found


def test_the_declared_types_are_found() -> None:
    declared = declared_types(ROOT)
    assert declared["::kemar::state"] == "components/kemar"
    assert declared["::capture::port_t"] == "components/capture"
    assert declared["::binaudio::portStruct"] == "components/bass"
    assert len(declared) > 30


def test_no_type_name_is_spelt_outside_its_component() -> None:
    assert strangers(ROOT) == []


def test_a_type_name_compared_elsewhere_is_found(tmp_path: pathlib.Path) -> None:
    """The search finds what the old tables held: a comparison, a dict key, a tuple of names."""
    (tmp_path / "components" / "kemar").mkdir(parents=True)
    (tmp_path / "components" / "kemar" / "_types.py").write_text('@idl_struct("kemar::state")\nclass S: ...\n')
    (tmp_path / "gateway").mkdir()
    (tmp_path / "gateway" / "_view.py").write_text(
        'def shown(kind):\n    return kind == "::kemar::state" or kind in {"kemar::state": 1}\n')
    for top in ("clients", "remote", "record"):
        (tmp_path / top).mkdir()
    assert [line.split(":")[0:2] for line in strangers(tmp_path)] == [["gateway/_view.py", "2"]] * 2
