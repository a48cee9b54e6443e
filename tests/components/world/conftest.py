"""The world's tests leave no process behind: the render process ends with its world."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest


def child_processes() -> set[int]:
    """The ids of this process's running children (zombies included: a child never waited for)."""
    children = set()
    for task in Path(f"/proc/{os.getpid()}/task").iterdir():
        try:
            text = (task / "children").read_text()
        except OSError:
            continue  # a thread that ended meanwhile (an executor's worker, a recording's writer) has none
        children.update(int(pid) for pid in text.split())
    return children


@pytest.fixture(autouse=True)
def no_child_processes() -> Iterator[None]:
    """Fail a test that leaves a child process (a render process) running after its world is gone."""
    before = child_processes()
    yield
    left = child_processes() - before
    assert not left, f"the test left child processes: {sorted(left)}"
