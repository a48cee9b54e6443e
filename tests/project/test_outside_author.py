"""An author outside the repository type-checks a component against the installed package, with no configuration.

The editable install is a tree of links named ``aiogenomix.*`` (setuptools' strict mode): mypy,
pyright and IDEs resolve it as they resolve any installed package, so an outside author's
``mypy --strict my_component.py`` sees the real types, not ``Any``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


COMPONENT = '''
from typing import Annotated

from aiogenomix.components.core import Component, Double, OutPort, activity, idl_struct


@idl_struct("lamp::state")
class State:
    """How bright the lamp is."""

    level: Annotated[Double, "From 0 to 1"] = 0.0


class Lamp(Component, name="lamp"):
    """A lamp that dims."""

    Level = OutPort(State, doc="The brightness")

    async def on_start(self) -> None:
        self.Level.publish(State())

    @activity
    async def Dim(self, to: Annotated[Double, "Target level"] = 0.0) -> None:
        """Dim the lamp to a level."""
        self.Level.publish(State(to))


reveal_type(Component)
reveal_type(Lamp.Level)
'''


def test_mypy_strict_sees_the_installed_package(tmp_path: Path) -> None:
    source = tmp_path / "lamp.py"
    source.write_text(COMPONENT, encoding="utf-8")
    # Run from the author's directory: no pyproject.toml of ours, no flags beyond --strict and the file.
    run = subprocess.run([sys.executable, "-m", "mypy", "--strict", source.name], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    out = run.stdout
    assert "error" not in out, out
    assert 'Revealed type is "def (host: aiogenomix.components.core._host.ComponentHost' in out, out
    assert "aiogenomix.components.core._ports.OutPort[lamp.State]" in out, out
    assert "Any" not in out, out
    assert run.returncode == 0, out


def test_pyright_sees_the_installed_package(tmp_path: Path, pyright_tool: Path) -> None:
    pyright = str(pyright_tool)
    source = tmp_path / "lamp.py"
    source.write_text(COMPONENT, encoding="utf-8")
    run = subprocess.run([pyright, "--pythonpath", sys.executable, source.name], cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    out = run.stdout
    assert "0 errors" in out, out
    assert 'Type of "Component" is "type[Component]"' in out, out
