"""The code generator: a .py whose functions match the live ones, and a .pyi stub that parses."""

from __future__ import annotations

import ast
import importlib.util
import inspect
import pathlib
import sys

import pytest
from aiogenomix.clients import connect
from aiogenomix.clients.codegen import main


def _import(path: pathlib.Path) -> object:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_generated_file_matches_the_live_module(threaded_gateway_url: str, tmp_path: pathlib.Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "demo_client.py"
    assert main(["--url", threaded_gateway_url, "--load", "demo", "-o", str(out), "--pyi"]) == 0
    assert "demo_client.pyi" in capsys.readouterr().out
    ast.parse(out.with_suffix(".pyi").read_text())
    stub = out.with_suffix(".pyi").read_text()
    assert "def GotoPosition(posRef: float = ..., *, ack: Literal[True]" in stub
    assert "class TOO_FAR_AWAY(RemoteError):" in stub and "overshoot: float" in stub

    generated = _import(out)
    with connect(threaded_gateway_url) as client:
        demo = generated.bind(client)  # type: ignore[attr-defined]
        live = inspect.signature(demo.GotoPosition)
        written = inspect.signature(generated.GotoPosition)  # type: ignore[attr-defined]
        assert [(p.name, p.default, p.kind) for p in written.parameters.values()] == [
            (p.name, p.default, p.kind) for p in live.parameters.values()]
        assert inspect.getdoc(generated.GotoPosition) == inspect.getdoc(demo.GotoPosition)  # type: ignore[attr-defined]
        assert generated.GotoPosition(0.5) is None  # type: ignore[attr-defined]
        request = generated.GotoPosition(0.6, ack=True)  # type: ignore[attr-defined]
        assert request.result() is None
        assert generated.Mobile().position == 0.6  # type: ignore[attr-defined]
        with pytest.raises(generated.TOO_FAR_AWAY) as caught:  # type: ignore[attr-defined]
            demo.GotoPosition(3)                   # the live module raises the file's class
        assert caught.value.overshoot == 2.0


def test_unreachable_gateway(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--url", "127.0.0.1:1", "demo", "-o", str(tmp_path / "x.py")]) == 1
    assert "cannot read /module/demo/info" in capsys.readouterr().err
    assert sys.modules.get("x") is None
