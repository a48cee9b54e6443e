"""docs/writing_a_component.md runs: its Python blocks in order, then its blocking client against a gateway."""

from __future__ import annotations

import asyncio
import pathlib
import re
import sys
import types
from collections.abc import Iterator
from typing import Any

import pytest

from aiogenomix.components.core import ComponentHost
from aiogenomix.gateway import GatewayConfig, serve

PAGE = pathlib.Path(__file__).resolve().parents[2] / "docs" / "writing_a_component.md"


@pytest.fixture
def page(capsys: pytest.CaptureFixture[str]) -> Iterator[dict[str, Any]]:
    """The page's Python blocks run in order in one module (what they print goes to *capsys*)."""
    blocks = re.findall(r"^```python\n(.*?)^```", PAGE.read_text(encoding="utf-8"), re.MULTILINE | re.DOTALL)
    assert len(blocks) >= 6
    module = types.ModuleType("writing_a_component")
    sys.modules[module.__name__] = module  # struct hints are resolved in their module, as for any file
    try:
        for block in blocks:
            exec(compile(block, str(PAGE), "exec"), module.__dict__)
        yield module.__dict__
    finally:
        del sys.modules[module.__name__]


def test_the_page_runs_from_nothing_to_generated_client_functions(
        page: dict[str, Any], capsys: pytest.CaptureFixture[str]) -> None:
    shown = capsys.readouterr().out
    assert "done {'reached': {'pan': 20.0, 'tilt': -5.0}}" in shown
    assert "error {'ex': '::pantilt::OUT_OF_RANGE', 'detail': {'axis': 'pan', 'limit': 170.0}}" in shown
    assert "the follower points at Angles(pan=-20.0, tilt=0.0)" in shown
    # help(): its signature (which pydoc wraps on 3.13) and its docstring
    assert "async Point(" in shown and "pan: float = 0.0" in shown and "ack: bool = False" in shown
    assert "OUT_OF_RANGE: ::pantilt::OUT_OF_RANGE." in shown and "\ntilt 30.0\n" in shown
    assert "@function has no option 'interupts' (did you mean 'interrupts'?)" in shown
    assert "pointed at 60.0 after True" in shown
    assert "speed (--pantilt-speed) takes a number, 1 or more, not 0.0" in shown

    async def point_twice_on_a_gateway() -> list[float]:
        factories = {"pantilt": page["PanTilt"], "counting_pantilt": page["CountingPanTilt"]}
        async with ComponentHost(factories=factories) as host, serve(GatewayConfig.of(port=0), host) as url:
            # The blocking client of the page, in a thread: this one runs the gateway.
            reached = await asyncio.to_thread(page["point_twice"], url)
            counting = await host.load("counting_pantilt")
            request = await counting.send("Point", {"pan": 10})
            await request.ended.wait()
            assert (request.status, page["CountingPanTilt"].motions) == ("done", 1)
            return reached

    assert asyncio.run(point_twice_on_a_gateway()) == [45.0, -45.0]
