"""Why a Zenoh endpoint a process connects to has no link: nothing answers there, or it refuses this session.

Zenoh retries a connect endpoint in the background and says nothing to its user: a gateway whose
password the robot refuses just never finds the robot's components. A TCP connection tells the two
cases apart: a port that accepts one but gives no Zenoh link refused this session (its user and
password, its certificate, or its access control), where a port that accepts none is down or cut off.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
from collections.abc import Iterable

import zenoh

from ._session import connect_endpoints

__all__ = ["why_unlinked", "unlinked", "report_unlinked", "LINK_GRACE"]

log = logging.getLogger(__name__)

#: Seconds after its start a session should have linked to its connect endpoints (Zenoh tries every second).
LINK_GRACE = 3.0
#: Seconds a TCP connection to an endpoint may take before it counts as unanswered.
_PROBE_TIMEOUT = 2.0


def _address(endpoint: str) -> tuple[str, str, int] | None:
    """``(protocol, host, port)`` of a ``tcp/`` or ``tls/`` *endpoint* (None for another protocol)."""
    protocol, _, place = endpoint.split("?", 1)[0].split("#", 1)[0].partition("/")
    host, _, port = place.rpartition(":")
    if protocol not in ("tcp", "tls") or not port.isdigit():
        return None
    return protocol, host.strip("[]"), int(port)


def _addresses(host: str, port: int) -> set[tuple[str, int]]:
    """Every (address, port) *host* names (itself when it is an address; nothing when it cannot be resolved)."""
    with contextlib.suppress(OSError):
        return {(str(info[4][0]), port) for info in socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)}
    return set()


def unlinked(session: zenoh.Session, endpoints: Iterable[str]) -> list[str]:
    """The ``tcp/`` and ``tls/`` *endpoints* *session* has no link to now."""
    linked: set[tuple[str, int]] = set()
    for link in session.info.links():
        found = _address(str(link.dst))
        if found is not None:
            linked.add((found[1], found[2]))
    missing = []
    for endpoint in endpoints:
        found = _address(endpoint)
        if found is not None and not _addresses(found[1], found[2]) & linked:
            missing.append(endpoint)
    return missing


def why_unlinked(endpoint: str) -> str:
    """Why a session has no link to *endpoint*, as far as a TCP connection to it can tell (blocking)."""
    found = _address(endpoint)
    if found is None:
        return "no link yet"
    _, host, port = found
    try:
        with socket.create_connection((host, port), timeout=_PROBE_TIMEOUT):
            pass
    except OSError as exc:
        return (f"nothing answers there ({exc.strerror or exc}): the process that listens there is down, or the "
                f"network between is cut")
    return ("it accepts connections but refused this Zenoh session: check the user and password (or the "
            "certificate) this process's --zenoh-config gives, and that the other side's access control "
            "allows it; its own log says why")


async def report_unlinked(session: zenoh.Session, config: zenoh.Config, grace: float = LINK_GRACE) -> None:
    """After *grace* seconds, log one line per connect endpoint of *config* that *session* has no link to."""
    await asyncio.sleep(grace)  # Zenoh's own attempts first: it retries every second
    for endpoint in unlinked(session, connect_endpoints(config)):
        why = await asyncio.to_thread(why_unlinked, endpoint)
        log.warning("no Zenoh link to %s after %g s: %s", endpoint, grace, why)
