"""Issue 10 acceptance 5: the notebook shows both robots' cameras and the PR2's path; executed here."""

from __future__ import annotations

import importlib.util
import pathlib
import re

import pytest

EXAMPLES = pathlib.Path(__file__).resolve().parents[3] / "examples"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

pytestmark = pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="mujoco is not installed")


def test_virtual_robots_notebook(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    # The kernel inherits these: a fast in-process simulation, small cameras, the figures under tmp_path.
    monkeypatch.setenv("AIOGENOMIX_TIME_SCALE", "5")
    monkeypatch.setenv("AIOGENOMIX_CAMERA_SIZE", "96x96")
    monkeypatch.setenv("AIOGENOMIX_PLOT_DIR", str(tmp_path))
    monkeypatch.delenv("AIOGENOMIX_URL", raising=False)
    notebook = nbformat.read(EXAMPLES / "virtual_robots.ipynb", as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=120, kernel_name="python3",
                                     resources={"metadata": {"path": str(EXAMPLES)}})
    client.execute()
    nbformat.write(notebook, tmp_path / "executed.ipynb")
    for name in ("virtual_cameras.png", "pr2_path.png"):
        assert (tmp_path / name).read_bytes().startswith(PNG_MAGIC)
    text = "".join(o.get("text", "") for cell in notebook.cells for o in cell.get("outputs", []))
    head = re.search(r"KEMAR head: (\S+) deg", text)
    assert head is not None and abs(float(head[1]) - 45) <= 0.5
    at = re.search(r"goal \(2.0, -1.5, -1.2\): at x=(\S+) m, y=(\S+) m, w=(\S+) deg", text)
    assert at is not None and abs(float(at[1]) - 2.0) <= 0.02 and abs(float(at[2]) + 1.5) <= 0.02
    assert abs(float(at[3]) - (-1.2 * 180 / 3.141592653589793)) <= 1.0
    assert "refused: ::pr2::INVALID_TORSO" in text
    images = [o for cell in notebook.cells for o in cell.get("outputs", []) if "image/png" in o.get("data", {})]
    assert len(images) == 2
