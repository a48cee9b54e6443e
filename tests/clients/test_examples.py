"""Acceptance 5: the example script and notebook drive demo and plot Mobile.position; both are executed here."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

EXAMPLES = pathlib.Path(__file__).resolve().parents[2] / "examples"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_demo_session_script(tmp_path: pathlib.Path) -> None:
    out = tmp_path / "positions.png"
    done = subprocess.run([sys.executable, str(EXAMPLES / "demo_session.py"), "--time-scale", "20", "--out", str(out)],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    assert "demo::0: sent" in done.stdout and "demo::0: done" in done.stdout
    assert "overshoot 1.0 m" in done.stdout
    assert out.read_bytes().startswith(PNG_MAGIC)


def test_demo_notebook(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    out = tmp_path / "demo_positions.png"
    # The kernel inherits these: a fast in-process simulation, and the plot written under tmp_path.
    monkeypatch.setenv("AIOGENOMIX_TIME_SCALE", "20")
    monkeypatch.setenv("AIOGENOMIX_PLOT_DIR", str(tmp_path))
    monkeypatch.delenv("AIOGENOMIX_URL", raising=False)
    notebook = nbformat.read(EXAMPLES / "demo_notebook.ipynb", as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=120, kernel_name="python3",
                                     resources={"metadata": {"path": str(EXAMPLES)}})
    client.execute()
    assert out.read_bytes().startswith(PNG_MAGIC)
    text = "".join(o.get("text", "") for cell in notebook.cells for o in cell.get("outputs", []))
    assert "done" in text and "overshoot 1.0 m" in text
