"""The gateway's own settings groups: where it listens, who may use it, its sessions, its live view, its remotes.

Each is a settings group (``aiogenomix.components.core.SettingsGroup``): every setting's default,
flag, unit, help and refusal are declared once, here, and ``aiogenomix-gateway`` makes its options
from them.  The groups of the rig (``HostSettings``, ``ClockSettings``, ``Budgets``), of a
connection (:class:`~._connection.ConnectionLimits`) and of Zenoh (``ZenohSettings``,
``RemoteTimeouts``) are declared where they are used; :class:`~._config.GatewayConfig` holds them all.
"""

from __future__ import annotations

import dataclasses

from ..components.core import SettingsGroup, at_least, setting, tcp_port, whole_at_least
from ..components.core.runtime import MIB, parse_amount

__all__ = ["ServerSettings", "AccessSettings", "SessionLimits", "LiveViewSettings", "RemoteComponents"]


def _names(text: str) -> tuple[str, ...] | None:
    """A comma-separated list of names (none given: None)."""
    return tuple(name.strip() for name in text.split(",") if name.strip()) or None


@dataclasses.dataclass(frozen=True)
class ServerSettings(SettingsGroup, section="gateway", about="where it listens and what it loads"):
    """Where the gateway listens and what it loads.

    Attributes:
        host: Address to bind (``127.0.0.1``: reachable from this machine only).
        port: HTTP port (0 picks a free one).
        components: When set, only these components can be loaded.
        preload: Components loaded at start, as ``name`` or ``name:-i instance``.
    """

    host: str = setting("127.0.0.1", flag="--host", help="address to bind")
    port: int = setting(8080, flag="--port", refuse=tcp_port, help="HTTP port, 0 for a free one")
    components: tuple[str, ...] | None = setting(None, flag="--components", parse=_names,
                                                 help="comma-separated allow-list of loadable components")
    preload: tuple[str, ...] = setting((), flag="--load", metavar="NAME[:ARGS]",
                                       help="load a component at start (repeatable), e.g. demo, or 'demo:-i demo2' "
                                            "(quoted: it holds a space)")


@dataclasses.dataclass(frozen=True)
class AccessSettings(SettingsGroup, section="access", about="who may use the gateway (decision 0036)"):
    """Who may use the gateway.

    Attributes:
        token: When set, every request must carry ``Authorization: Bearer <token>`` (empty: none).
        allowed_hosts: Host names browsers may use for the gateway besides IP addresses,
            ``localhost`` and this machine's names (DNS-rebinding protection; ``*``: any).
        allowed_origins: Web origins whose pages may use the gateway (cross-site protection).
    """

    token: str | None = setting(None, flag="--token", env="AIOGENOMIX_TOKEN",
                                help="require 'Authorization: Bearer TOKEN'; better given as $AIOGENOMIX_TOKEN, "
                                     "which other users cannot read in the process list (unset: open)")
    allowed_hosts: tuple[str, ...] = setting((), flag="--allowed-host", metavar="NAME",
                                             help="a host name browsers may reach the gateway by, besides IP "
                                                  "addresses, localhost and this machine's names (repeatable; '*' "
                                                  "for any)")
    allowed_origins: tuple[str, ...] = setting((), flag="--allow-origin", metavar="ORIGIN",
                                               help="a web origin (scheme://host:port) whose pages may use the "
                                                    "gateway (repeatable)")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.token == "":
            object.__setattr__(self, "token", None)


@dataclasses.dataclass(frozen=True)
class SessionLimits(SettingsGroup, section="limits", about="what one client can hold or send"):
    """How many sessions and instances, and how long they last.

    Attributes:
        session_idle: Seconds after which a session that nobody listens to is forgotten.
        max_sessions: How many sessions may exist at once (429 for a new one beyond).
        max_instances: How many component instances may be loaded at once (429 beyond).
        ping_interval: Seconds between keep-alive comments on idle event streams.
        function_grace: How long a ``send`` waits for a function to end before replying ``sent``.
    """

    session_idle: float = setting(600.0, flag="--session-idle", unit="seconds", refuse=at_least(0.001),
                                  help="a session nobody listens to is forgotten after this long unused")
    max_sessions: int = setting(256, flag="--max-sessions", metavar="N", refuse=whole_at_least(1),
                                help="most sessions at once, else 429")
    max_instances: int = setting(64, flag="--max-instances", metavar="N", refuse=whole_at_least(1),
                                 help="most component instances loaded at once, else 429")
    ping_interval: float = 15.0
    function_grace: float = 2.0


@dataclasses.dataclass(frozen=True)
class LiveViewSettings(SettingsGroup, section="live view",
                       about="the robot's head, cameras, odometry, laser and audio in Foxglove or Lichtblick (the "
                             "Foxglove WebSocket protocol; pip install aiogenomix[foxglove])"):
    """The live view in Foxglove and Lichtblick.

    Attributes:
        foxglove_port: Serve the live view on this TCP port (None: no view; 0: a free port).  It
            admits viewers as the gateway admits requests: Host, Origin and token (decision 0036).
        foxglove_host: The address the live view binds (the loopback address unless the operator says so).
        max_viewers: How many viewers may be connected at once (429 for one more).
        viewer_bytes: The most bytes one viewer may hold unsent; a viewer past it is dropped.
    """

    foxglove_port: int | None = setting(None, flag="--foxglove", metavar="PORT", parse=int, refuse=tcp_port,
                                        help="serve the live view on this port (0 for a free one; default: no "
                                             "view); it admits viewers as the gateway admits requests (--token as "
                                             "ws://HOST:PORT/?token=..., --allow-origin, --allowed-host)")
    foxglove_host: str = setting("127.0.0.1", flag="--foxglove-host", metavar="ADDRESS", shown="127.0.0.1: this "
                                 "machine only", help="address of the live view")
    max_viewers: int = setting(8, flag="--max-viewers", metavar="N", refuse=whole_at_least(1),
                               help="most viewers connected at once, else 429")
    viewer_bytes: int = setting(32 * MIB, flag="--max-viewer-bytes", unit="bytes", parse=parse_amount,
                                refuse=whole_at_least(1),
                                help="bytes one viewer may hold unsent (it does not read, or falls ever further "
                                     "behind) before it is dropped")


@dataclasses.dataclass(frozen=True)
class RemoteComponents(SettingsGroup, section="remote components",
                       about="components that run in other processes or on other hosts (aiogenomix-component), "
                             "found on Zenoh; the gateway talks to nobody but the endpoints given"):
    """Whether the gateway loads components other processes offer, and which run here all the same.

    Attributes:
        zenoh: Load components that other processes offer on Zenoh (``aiogenomix-component``);
            every name then runs where a component host offers it, except the ``local`` ones.
            A Zenoh endpoint, configuration file or scouting given on the command line implies it.
        local: Component names that run in the gateway even with ``zenoh`` (an explicit choice: a
            host that restarts can never be replaced by a copy in the gateway).
    """

    zenoh: bool = setting(False, flag="--zenoh",
                          help="load components offered on Zenoh (implied by the Zenoh options): every name then "
                               "runs where a host offers it, never in this gateway unless named with --local")
    local: tuple[str, ...] = setting((), flag="--local", metavar="NAME",
                                     help="a component that runs in this gateway even with remote components "
                                          "(repeatable); any other name runs only where a component host offers it")
