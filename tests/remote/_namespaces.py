"""Network namespaces for tests across hosts: a robot's and a workstation's, joined by a veth pair.

The namespaces, the link and its link-local addresses (169.254.77.0/30, never routed) exist only
for the test and are removed after it, whatever happened.  Root is needed to create them: the
tests are skipped, saying why, where they cannot.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import json
import os
import shutil
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator

import pytest

#: The robot's address on the link, and the workstation's.
ROBOT_ADDRESS = "169.254.77.1"
WORKSTATION_ADDRESS = "169.254.77.2"


def ip(*args: str) -> None:
    """Run ``ip ARGS`` (raises on failure)."""
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=10)


@dataclasses.dataclass(frozen=True)
class Lab:
    """Two namespaces: a robot's and a workstation's, and the workstation's end of their link."""

    robot: str
    workstation: str
    link: str = "agxw"

    def on_robot(self) -> list[str]:
        """The prefix of a command run on the robot."""
        return ["ip", "netns", "exec", self.robot]

    def on_workstation(self) -> list[str]:
        """The prefix of a command run on the workstation."""
        return ["ip", "netns", "exec", self.workstation]

    def cut(self, cut: bool = True) -> None:
        """Cut the link between them (no reset, no answer: a cable pulled), or mend it."""
        ip("-n", self.workstation, "link", "set", self.link, "down" if cut else "up")


@contextlib.contextmanager
def lab() -> Iterator[Lab]:
    """Two fresh network namespaces joined by a veth pair (skips the test where they cannot be made)."""
    if shutil.which("ip") is None:
        pytest.skip("the ip command (iproute2) is not installed: cannot create network namespaces")
    if os.geteuid() != 0:
        pytest.skip("creating network namespaces needs root")
    robot, workstation = f"agx{os.getpid()}r", f"agx{os.getpid()}w"
    try:
        ip("netns", "add", robot)
    except subprocess.CalledProcessError as exc:
        pytest.skip(f"ip netns is unavailable here: {exc.stderr.decode().strip()}")
    try:
        ip("netns", "add", workstation)
        # Created inside the namespaces: the link never touches the machine's own interfaces.
        ip("-n", robot, "link", "add", "agxr", "type", "veth", "peer", "name", "agxw", "netns", workstation)
        ip("-n", robot, "addr", "add", f"{ROBOT_ADDRESS}/30", "dev", "agxr")
        ip("-n", workstation, "addr", "add", f"{WORKSTATION_ADDRESS}/30", "dev", "agxw")
        for namespace, link in ((robot, "agxr"), (workstation, "agxw")):
            ip("-n", namespace, "link", "set", "lo", "up")
            ip("-n", namespace, "link", "set", link, "up")
        yield Lab(robot, workstation)
    finally:
        # Deleting a namespace deletes its end of the link, and the pair with it.
        for namespace in (robot, workstation):
            with contextlib.suppress(subprocess.CalledProcessError):
                ip("netns", "del", namespace)


async def run_in(prefix: list[str], *command: str, timeout: float = 60) -> str:
    """Run *command* under *prefix* (``ip netns exec NS``); return its output (fails on a non-zero status)."""
    process = await asyncio.create_subprocess_exec(*prefix, *command, stdout=asyncio.subprocess.PIPE,
                                                   stderr=asyncio.subprocess.PIPE)
    out, err = await asyncio.wait_for(process.communicate(), timeout)
    assert process.returncode == 0, f"{command}: {err.decode()}"
    return out.decode()


async def python_in(prefix: list[str], script: str, timeout: float = 60) -> object:
    """Run a Python *script* under *prefix*; return the JSON it prints last."""
    return json.loads((await run_in(prefix, sys.executable, "-c", script, timeout=timeout)).splitlines()[-1])


#: Waits for a packet received on interface argv[1] that holds the bytes argv[2]; says "ready", then "seen".
_SNIFFER = """
import socket, sys
interface, wanted = sys.argv[1], sys.argv[2].encode()
sniffer = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(0x0003))  # every protocol
sniffer.bind((interface, 0))
print("ready", flush=True)
while wanted not in sniffer.recv(65536):
    pass
print("seen", flush=True)
"""


@contextlib.asynccontextmanager
async def packet_seen(prefix: list[str], interface: str, wanted: bytes) -> AsyncIterator[asyncio.Future[bytes]]:
    """A future of ``b"seen\\n"`` once a packet holding *wanted* arrives on *interface* under *prefix*.

    Watching starts before the block runs. (Zenoh over TCP is clear text: a query's key and payload show.)
    """
    sniffer = await asyncio.create_subprocess_exec(*prefix, sys.executable, "-c", _SNIFFER, interface,
                                                   wanted.decode(), stdout=asyncio.subprocess.PIPE)
    assert sniffer.stdout is not None
    seen: asyncio.Future[bytes] | None = None
    try:
        assert await asyncio.wait_for(sniffer.stdout.readline(), 30) == b"ready\n"
        seen = asyncio.ensure_future(sniffer.stdout.readline())
        yield seen
    finally:
        if seen is not None:
            seen.cancel()
        if sniffer.returncode is None:
            sniffer.kill()
        await sniffer.wait()


async def curl(prefix: list[str], url: str) -> tuple[int, object]:
    """GET *url* with curl under *prefix*: the status and the body (JSON when it is)."""
    out = await run_in(prefix, "curl", "-s", "--max-time", "30", "-w", "\n%{http_code}", url)
    text, _, code = out.rpartition("\n")
    try:
        return int(code), json.loads(text)
    except json.JSONDecodeError:
        return int(code), text
