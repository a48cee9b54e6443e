"""Gateways and component hosts as separate processes on loopback, started and always ended by the tests.

Every Zenoh session here names its endpoints on 127.0.0.1 (or on the test's private links), so
multicast scouting is off: the tests never discover, nor are discovered by, anything else.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import signal
import socket
import sys
from collections.abc import AsyncIterator, Sequence

#: How much faster than real time the simulated rigs of these tests run.
TIME_SCALE = 20.0


def free_port(address: str = "127.0.0.1") -> int:
    """A TCP port nobody listens on now."""
    with socket.socket() as probe:
        probe.bind((address, 0))
        return int(probe.getsockname()[1])


class Process:
    """One child process, its stderr read line by line (what a user sees in its terminal)."""

    def __init__(self, process: asyncio.subprocess.Process, name: str) -> None:
        self.process = process
        self.name = name
        self.lines: list[str] = []
        self._drains: list[asyncio.Task[None]] = []

    @property
    def pid(self) -> int:
        return self.process.pid

    async def line_matching(self, pattern: str, stream: str = "stderr", timeout: float = 60.0) -> re.Match[str]:
        """Read lines until one matches *pattern* (fails with what was read when the process ends first)."""
        reader = self.process.stderr if stream == "stderr" else self.process.stdout
        assert reader is not None
        async with asyncio.timeout(timeout):
            while True:
                line = (await reader.readline()).decode()
                if not line:
                    raise AssertionError(f"{self.name} ended before saying {pattern!r}:\n{''.join(self.lines)}")
                self.lines.append(line)
                found = re.search(pattern, line)
                if found:
                    return found

    def drain(self) -> None:
        """Keep reading its output so that it never blocks on a full pipe."""
        for reader in (self.process.stdout, self.process.stderr):
            if reader is not None:
                self._drains.append(asyncio.get_running_loop().create_task(_discard(reader)))

    def kill(self, signum: int = signal.SIGKILL) -> None:
        """Send *signum* (SIGKILL: the process dies at once, as in a crash)."""
        if self.process.returncode is None:
            self.process.send_signal(signum)

    async def end(self) -> None:
        """Stop it (SIGTERM, then SIGKILL after 10 s), reap it, and finish reading what it wrote."""
        if self.process.returncode is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                await asyncio.wait_for(self.process.wait(), 10)
            except TimeoutError:
                self.process.kill()
        await self.process.wait()
        await asyncio.gather(*self._drains, return_exceptions=True)


async def _discard(reader: asyncio.StreamReader) -> None:
    with contextlib.suppress(Exception):
        while await reader.read(65536):
            pass


async def start_component_host(names: Sequence[str], *, listen: str | None = None, connect: Sequence[str] = (),
                               extra: Sequence[str] = (), prefix: Sequence[str] = (),
                               host_id: str = "robot") -> Process:
    """``aiogenomix-component NAMES...``; returns once it offers them (run under *prefix*, e.g. ``ip netns exec``)."""
    args = [*names, "--host-id", host_id, "--time-scale", str(TIME_SCALE), "--audio-socket-port", "0", *extra]
    if listen:
        args += ["--zenoh-listen", listen]
    for endpoint in connect:
        args += ["--zenoh-connect", endpoint]
    process = await asyncio.create_subprocess_exec(
        *prefix, sys.executable, "-m", "aiogenomix.remote._host_main", *args,
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )
    host = Process(process, f"component host {' '.join(names)}")
    try:
        await host.line_matching(r"offering .* on Zenoh")
    except BaseException:
        await host.end()
        raise
    host.drain()
    return host


async def start_gateway(connect: Sequence[str] = (), *, listen: str | None = None, extra: Sequence[str] = (),
                        address: str = "127.0.0.1", prefix: Sequence[str] = (),
                        drain: bool = True) -> tuple[Process, str]:
    """The gateway with ``--zenoh``; returns it with its base URL once it listens.

    With *drain* false, its output is left for the caller to read (``line_matching``).
    """
    args = ["--host", address, "--port", "0", "--audio-socket-port", "0", "--time-scale", str(TIME_SCALE),
            "--zenoh", *extra]
    for endpoint in connect:
        args += ["--zenoh-connect", endpoint]
    if listen:
        args += ["--zenoh-listen", listen]
    process = await asyncio.create_subprocess_exec(
        *prefix, sys.executable, "-m", "aiogenomix.gateway", *args,
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )
    gateway = Process(process, "gateway")
    try:
        url = (await gateway.line_matching(r"listening on (http://\S+)", stream="stdout")).group(1)
    except BaseException:
        await gateway.end()
        raise
    if drain:
        gateway.drain()
    return gateway, url


#: A Zenoh router, as zenohd runs one, from the Python package (zenohd is not on the package index).
_ROUTER = """
import json, sys, threading, zenoh
config = zenoh.Config()
for key, value in (("mode", '"router"'), ("scouting/multicast/enabled", "false"),
                   ("scouting/gossip/enabled", "false"), ("listen/endpoints", json.dumps([sys.argv[1]]))):
    config.insert_json5(key, value)
session = zenoh.open(config)
print("router ready", file=sys.stderr, flush=True)
threading.Event().wait()
"""


async def start_router(listen: str, *, prefix: Sequence[str] = ()) -> Process:
    """A Zenoh router listening on *listen*; returns once it does (run under *prefix*, e.g. ``ip netns exec``)."""
    process = await asyncio.create_subprocess_exec(
        *prefix, sys.executable, "-c", _ROUTER, listen, stdin=asyncio.subprocess.DEVNULL,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    router = Process(process, "router")
    try:
        await router.line_matching("router ready")
    except BaseException:
        await router.end()
        raise
    router.drain()
    return router


async def start_host_and_gateway(started: list[Process], names: Sequence[str], *, extra: Sequence[str] = (),
                                 gateway_extra: Sequence[str] = ()) -> tuple[Process, str, str]:
    """A component host running *names* on a loopback endpoint, and a gateway that finds them.

    *extra* and *gateway_extra* are more options of each.  Both are added to *started*.  Returns the
    host, the gateway's base URL and the host's endpoint.
    """
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    host = await start_component_host(names, listen=endpoint, extra=extra)
    started.append(host)
    gateway, url = await start_gateway([endpoint], extra=gateway_extra)
    started.append(gateway)
    return host, url, endpoint


@contextlib.asynccontextmanager
async def processes() -> AsyncIterator[list[Process]]:
    """A list to put started processes in; every one is ended on the way out, whatever happened."""
    started: list[Process] = []
    try:
        yield started
    finally:
        await asyncio.gather(*(p.end() for p in started), return_exceptions=True)
