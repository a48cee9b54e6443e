"""The client package knows only the wire contract: it imports nothing from the gateway or the components."""

from __future__ import annotations

import ast
import pathlib

from aiogenomix import clients

FORBIDDEN = ("gateway", "components")


def test_clients_import_neither_gateway_nor_components() -> None:
    root = pathlib.Path(clients.__file__).parent
    offenders = []
    for path in sorted(root.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [("." * node.level) + (node.module or "")]
                if node.level >= 2 or (node.module or "").startswith("aiogenomix."):
                    names += [f"{names[0]}.{alias.name}" for alias in node.names]
            for name in names:
                parts = name.lstrip(".").split(".")
                if any(part in FORBIDDEN for part in parts):
                    offenders.append(f"{path.name}: {name}")
    assert offenders == []


def test_public_face() -> None:
    for name in clients.__all__:
        assert hasattr(clients, name), name
    assert clients.connect.__module__ == "aiogenomix.clients"
    assert (pathlib.Path(clients.__file__).parent / "py.typed").exists()
