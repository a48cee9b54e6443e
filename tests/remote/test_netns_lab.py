"""The lab of network namespaces shared by the many-host tests and the scale benchmark (``bench/_netns.py``).

A run killed before it could delete its namespaces (a timeout, a CI job cancelled) must not leave them on
the machine for ever; a run still going must keep its own. Needs root and ``ip``.
"""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

from bench._netns import namespaces as listed, star, unavailable

ROOT = pathlib.Path(__file__).resolve().parents[2]

#: A process that makes a star with one machine, starts a process there (as a run starts its hosts), says the
#: star's prefix and that process's id, then waits for a line on its input.
OWNER = """
import subprocess, sys
from bench._netns import star
with star() as lab:
    lab.add("m1")
    host = subprocess.Popen([*lab.on("m1"), "sleep", "300"])
    print(lab.prefix, host.pid, flush=True)
    sys.stdin.readline()
    host.kill()
    host.wait()
"""


def namespaces() -> set[str]:
    """The names of the machine's network namespaces, as a set."""
    return set(listed())


def start_owner() -> tuple[subprocess.Popen[str], str, int]:
    """A process holding a star, the star's prefix, and the id of the process it runs in the star's machine."""
    owner = subprocess.Popen([sys.executable, "-c", OWNER], cwd=ROOT, text=True,
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert owner.stdout is not None
    prefix, host = owner.stdout.readline().split()
    return owner, prefix, int(host)


def running(pid: int) -> bool:
    """Whether process *pid* exists and is not a zombie."""
    try:
        return pathlib.Path(f"/proc/{pid}/stat").read_text().split(") ", 1)[1][0] != "Z"
    except (FileNotFoundError, IndexError):
        return False


def test_the_next_star_deletes_a_killed_runs_namespaces_and_keeps_a_live_ones() -> None:
    why = unavailable()
    if why is not None:
        pytest.skip(why)
    killed, killed_prefix, orphan = start_owner()
    live, live_prefix, host = start_owner()
    try:
        killed.kill()
        killed.wait(timeout=30)
        left = {f"{killed_prefix}-hub", f"{killed_prefix}-m1"}
        kept = {f"{live_prefix}-hub", f"{live_prefix}-m1"}
        assert left | kept <= namespaces()

        assert running(orphan), "what a killed run started in its star goes on running"

        with star() as lab:
            assert not left & namespaces()
            assert not running(orphan), "and goes with the star"
            assert kept | {lab.hub} <= namespaces()
            assert running(host)
    finally:
        for owner in (killed, live):
            owner.communicate("\n", timeout=30)  # the live one leaves; both pipes closed
    assert not kept & namespaces(), "a star is deleted by its own process on the way out"
