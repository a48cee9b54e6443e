"""A lab of network namespaces on one machine: a hub (the router's) and machines linked to it by a bridge.

Each machine is a namespace of its own with one interface, ``agx0``, whose veth peer is a port of
the bridge ``agxbr`` in the hub; every address is link-local (169.254.78.0/24: never routed, and
never one of the machine's own). Nothing exists outside the namespaces, and :meth:`Star.close`
(or leaving :func:`star`) deletes them all, whatever happened but the process's death: a star
left by a process that was killed is deleted by the next :func:`star` on the machine, with what
still runs in it. Creating them needs root and ``ip``.

Shared by the scale benchmark and the tests that check what each host hears.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import re
import select
import shutil
import signal
import subprocess
from collections.abc import Iterator

__all__ = ["Star", "namespaces", "star", "sweep", "unavailable"]

#: The hub's address; machine *n* (from 1) has ``169.254.78.(n + 1)``.
_NET = "169.254.78"
#: Each machine's interface.
INTERFACE = "agx0"
#: The name of a namespace of a star named by its process (:func:`star`'s default prefix).
_OWNED = re.compile(r"agxs(\d+)-\S+")


def unavailable() -> str | None:
    """Why namespaces cannot be made here (None: they can)."""
    if shutil.which("ip") is None:
        return "the ip command (iproute2) is not installed: cannot create network namespaces"
    if os.geteuid() != 0:
        return "creating network namespaces needs root"
    return None


def _ip(*args: str) -> str:
    return subprocess.run(["ip", *args], check=True, capture_output=True, timeout=30, text=True).stdout


@dataclasses.dataclass
class Star:
    """The hub and the machines added so far (namespaces named ``PREFIX-hub``, ``PREFIX-NAME``).

    Attributes:
        prefix: What every namespace name starts with (unique per run: the process id).
        machines: The address of each machine added, by name.
    """

    prefix: str
    machines: dict[str, str] = dataclasses.field(default_factory=dict)

    @property
    def hub(self) -> str:
        """The hub's namespace (where the router runs)."""
        return f"{self.prefix}-hub"

    @property
    def hub_address(self) -> str:
        """The hub's address on the bridge."""
        return f"{_NET}.1"

    def namespace(self, name: str) -> str:
        """The namespace of machine *name* (``hub`` for the hub's)."""
        return self.hub if name == "hub" else f"{self.prefix}-{name}"

    def on(self, name: str) -> list[str]:
        """The prefix of a command run on machine *name* (``hub``: on the hub)."""
        return ["ip", "netns", "exec", self.namespace(name)]

    def open(self) -> None:
        """Create the hub: its namespace and its bridge, up."""
        _ip("netns", "add", self.hub)
        _ip("-n", self.hub, "link", "add", "agxbr", "type", "bridge")
        _ip("-n", self.hub, "addr", "add", f"{self.hub_address}/24", "dev", "agxbr")
        for link in ("lo", "agxbr"):
            _ip("-n", self.hub, "link", "set", link, "up")

    def add(self, name: str) -> str:
        """Add machine *name* linked to the hub; return its address."""
        number = len(self.machines) + 1
        if number > 250:
            raise ValueError("a star holds at most 250 machines")
        namespace, port = self.namespace(name), f"agxp{number}"
        address = f"{_NET}.{number + 1}"
        _ip("netns", "add", namespace)
        # Made inside the namespaces: the link never touches the machine's own interfaces.
        _ip("-n", self.hub, "link", "add", port, "type", "veth", "peer", "name", INTERFACE, "netns", namespace)
        _ip("-n", self.hub, "link", "set", port, "master", "agxbr")
        _ip("-n", namespace, "addr", "add", f"{address}/24", "dev", INTERFACE)
        for link in ("lo", INTERFACE):
            _ip("-n", namespace, "link", "set", link, "up")
        _ip("-n", self.hub, "link", "set", port, "up")
        self.machines[name] = address
        return address

    def received(self, name: str) -> tuple[int, int]:
        """The packets and bytes machine *name* has received on its interface so far."""
        stats = json.loads(_ip("-n", self.namespace(name), "-j", "-s", "link", "show", "dev", INTERFACE))[0]
        rx = stats["stats64"]["rx"]
        return int(rx["packets"]), int(rx["bytes"])

    def close(self) -> None:
        """Delete every namespace (a namespace's end of a link goes with it, and the pair with it)."""
        for namespace in [*map(self.namespace, self.machines), self.hub]:
            with contextlib.suppress(subprocess.CalledProcessError, subprocess.TimeoutExpired):
                _ip("netns", "del", namespace)
        self.machines.clear()


def namespaces() -> list[str]:
    """The names of the machine's network namespaces (``ip netns list``)."""
    return [line.split(" ", 1)[0] for line in _ip("netns", "list").splitlines()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        pass
    return True


def _kill(pid: int, timeout: float = 10.0) -> None:
    """Kill process *pid* and wait (at most *timeout* seconds) until it has ended."""
    try:
        handle = os.pidfd_open(pid)  # the process itself, whatever id the system gives out next
    except ProcessLookupError:
        return
    except OSError:  # a kernel before 5.3: no pidfd, a plain kill
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
        return
    try:
        signal.pidfd_send_signal(handle, signal.SIGKILL)
        select.select([handle], [], [], timeout)  # readable once it has ended
    except ProcessLookupError:
        pass
    finally:
        os.close(handle)


def sweep() -> list[str]:
    """Delete the namespaces of stars whose process is dead (killed before it could); return their names.

    Only names of :func:`star`'s default form (``agxs<pid>-...``) are touched, and only when no
    process has that id: a star in use, by this process or another, stays. What still runs in a
    swept namespace (a dead run's router or hosts, which would go on taking the machine's time) is
    killed with it.
    """
    swept = []
    for name in namespaces():
        owner = _OWNED.fullmatch(name)
        if owner is not None and not _alive(int(owner.group(1))):
            with contextlib.suppress(subprocess.CalledProcessError, subprocess.TimeoutExpired):
                for pid in _ip("netns", "pids", name).split():
                    _kill(int(pid))
                _ip("netns", "del", name)
                swept.append(name)
    return swept


@contextlib.contextmanager
def star(prefix: str | None = None) -> Iterator[Star]:
    """A :class:`Star` with its hub made; every namespace is deleted on the way out.

    The stars of processes that died before deleting theirs are deleted first (:func:`sweep`).

    Raises:
        RuntimeError: when namespaces cannot be made here (:func:`unavailable` says why).
    """
    why = unavailable()
    if why is not None:
        raise RuntimeError(why)
    sweep()
    lab = Star(prefix or f"agxs{os.getpid()}")
    try:
        lab.open()
        yield lab
    finally:
        lab.close()
