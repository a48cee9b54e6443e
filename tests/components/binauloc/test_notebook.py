"""Issue 25: the active-listening notebook runs the closed loop and draws its polar plot; executed here."""

from __future__ import annotations

import os
import pathlib
import re

import pytest

#: A Jupyter kernel and a closed loop: ./run runs it once, on the default Python (AIOGENOMIX_HEAVY=0 on the others).
pytestmark = pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0",
                                reason="the notebook runs once, on the default Python (AIOGENOMIX_HEAVY=0)")

EXAMPLES = pathlib.Path(__file__).resolve().parents[3] / "examples"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_active_listening_notebook(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    # The kernel inherits these: an in-process gateway on simulated time (examples/local_gateway.py: a VirtualClock
    # paced at most 50 times real time, which a busy machine slows down but never makes late: the loop asks for
    # its estimates from the audio after each request, so where the head looks and what it hears hold however
    # slow the kernel is), the figure and the scene under tmp_path.
    monkeypatch.setenv("AIOGENOMIX_TIME_SCALE", "50")
    monkeypatch.setenv("AIOGENOMIX_PLOT_DIR", str(tmp_path))
    monkeypatch.setenv("AIOGENOMIX_SCENE_DIR", str(tmp_path))
    monkeypatch.delenv("AIOGENOMIX_URL", raising=False)
    notebook = nbformat.read(EXAMPLES / "active_listening.ipynb", as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=120, kernel_name="python3",
                                     resources={"metadata": {"path": str(EXAMPLES)}})
    client.execute()
    nbformat.write(notebook, tmp_path / "executed.ipynb")
    assert (tmp_path / "active_listening.png").read_bytes().startswith(PNG_MAGIC)
    text = "".join(o.get("text", "") for cell in notebook.cells for o in cell.get("outputs", []))
    looks = re.search(r"the head looked from (.+) deg\n", text)
    assert looks is not None and len(looks[1].split(", ")) >= 2              # it turned at least once
    found = re.search(r"decision layer: found (\S+) deg \(posterior (\S+)\), head now at (\S+) deg", text)
    # Behind, not its mirror image in front (32.5°): the loop hears a few tenths of a second from each azimuth.
    assert found is not None and abs(float(found[1]) - 147.5) < 10.0 and float(found[2]) >= 0.9
    assert float(found[3]) == pytest.approx(89.5, abs=0.2)                  # the neck's limit, on its side
    inside = re.search(r"FaceSource: found (\S+) deg \(posterior (\S+)\), head at (\S+) deg, faced: (\w+)", text)
    assert inside is not None and abs(float(inside[1]) - 147.5) < 10.0 and inside[4] == "False"
    images = [o for cell in notebook.cells for o in cell.get("outputs", []) if "image/png" in o.get("data", {})]
    assert len(images) == 1
