"""The lab of network namespaces shared by the many-host tests and the scale benchmark (``bench/_netns.py``).

A run killed before it could delete its namespaces (a timeout, a CI job cancelled) must not leave them on
the machine for ever; a run still going must keep its own. Needs root and ``ip``.
"""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

from bench._netns import star, unavailable

ROOT = pathlib.Path(__file__).resolve().parents[2]

#: A process that makes a star with one machine, says its prefix, then waits for a line on its input.
OWNER = """
import sys
from bench._netns import star
with star() as lab:
    lab.add("m1")
    print(lab.prefix, flush=True)
    sys.stdin.readline()
"""


def namespaces() -> set[str]:
    """The names of the machine's network namespaces."""
    listed = subprocess.run(["ip", "netns", "list"], check=True, capture_output=True, text=True).stdout
    return {line.split(" ", 1)[0] for line in listed.splitlines()}


def start_owner() -> tuple[subprocess.Popen[str], str]:
    """A process holding a star, and the star's prefix."""
    owner = subprocess.Popen([sys.executable, "-c", OWNER], cwd=ROOT, text=True,
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert owner.stdout is not None
    return owner, owner.stdout.readline().strip()


def test_the_next_star_deletes_a_killed_runs_namespaces_and_keeps_a_live_ones() -> None:
    why = unavailable()
    if why is not None:
        pytest.skip(why)
    killed, killed_prefix = start_owner()
    live, live_prefix = start_owner()
    try:
        killed.kill()
        killed.wait(timeout=30)
        left = {f"{killed_prefix}-hub", f"{killed_prefix}-m1"}
        kept = {f"{live_prefix}-hub", f"{live_prefix}-m1"}
        assert left | kept <= namespaces()

        with star() as lab:
            assert not left & namespaces()
            assert kept | {lab.hub} <= namespaces()
    finally:
        for owner in (killed, live):
            owner.communicate("\n", timeout=30)  # the live one leaves; both pipes closed
    assert not kept & namespaces(), "a star is deleted by its own process on the way out"
