"""The settings groups of the remote layer: whom a Zenoh session talks to, and how long a gateway waits.

Plain data, without Zenoh: a gateway holds them in its configuration (and makes its options from
them) whether or not it asks for remote components; Zenoh is imported only by what opens a session.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from ..components.core import SettingsGroup, at_least, setting

if TYPE_CHECKING:
    import zenoh

__all__ = ["ZenohSettings", "RemoteTimeouts"]


@dataclasses.dataclass(frozen=True)
class ZenohSettings(SettingsGroup, section="Zenoh", about="whom this process talks to on Zenoh: nobody but the "
                                                          "endpoints given"):
    """Whom a Zenoh session talks to: endpoints, Zenoh's own configuration file, discovery.

    Isolated by default: a session connects to the ``connect`` endpoints and listens on the
    ``listen`` ones, and on nothing else.  No multicast scouting, no gossip (a session would
    otherwise connect to every locator it hears of, the machine's other addresses included), and
    no listener unless asked (Zenoh's own default listens on every interface).  Shared memory
    between processes of one machine carries only messages of 64 KiB or more, from a pool of 4 MiB
    (see ``_shm``).

    Attributes:
        connect: Endpoints to connect to, such as ``tcp/192.168.1.10:7447``.
        listen: Endpoints to listen on, such as ``tcp/192.168.1.10:7447``.
        config_file: A Zenoh configuration file (JSON5, Zenoh's own format: TLS, user/password
            authentication, access control, a router to connect to...).  Its settings are kept,
            even those it sets to Zenoh's default; ``connect`` and ``listen`` replace its endpoints
            when given.  A setting it leaves out (scouting, gossip, listeners, the mode, the shared
            memory's threshold and pool) is as above.
        scout: Find peers by multicast scouting and gossip, and listen on every interface
            (Zenoh's defaults): for a lab network where every machine is trusted.
    """

    connect: tuple[str, ...] = setting((), flag="--zenoh-connect", metavar="ENDPOINT",
                                       help="a Zenoh endpoint to connect to, e.g. tcp/192.168.1.10:7447 (repeatable)")
    listen: tuple[str, ...] = setting((), flag="--zenoh-listen", metavar="ENDPOINT",
                                      help="a Zenoh endpoint to listen on, e.g. tcp/192.168.1.10:7447 (repeatable; "
                                           "none by default: an address of this machine, tcp/0.0.0.0:7447 listens "
                                           "on every interface)")
    config_file: str | None = setting(None, flag="--zenoh-config", metavar="FILE",
                                      help="Zenoh's own configuration file (JSON5): TLS, user/password, access "
                                           "control, a router; --zenoh-connect and --zenoh-listen replace its "
                                           "endpoints")
    scout: bool = setting(False, flag="--zenoh-scout",
                          help="find peers by multicast scouting and gossip and listen on every interface (Zenoh's "
                               "defaults): only on a network where every machine is trusted")

    def given(self) -> bool:
        """Whether these settings say anything (an endpoint, a file, scouting): a gateway then uses Zenoh."""
        return bool(self.connect or self.listen or self.config_file or self.scout)

    def config(self) -> zenoh.Config:
        """The Zenoh configuration of a session with these settings (imports Zenoh).

        Raises:
            ZenohSessionError: for a configuration file that cannot be read, or settings whose
                session would talk to nobody.
        """
        from ._session import zenoh_config

        return zenoh_config(self)

    def summary(self, config: zenoh.Config) -> str:
        """What a session of *config* does, in one line for its start-up message."""
        from ._session import session_summary

        return session_summary(self, config)


@dataclasses.dataclass(frozen=True)
class RemoteTimeouts(SettingsGroup, section="remote components"):
    """How long the gateway waits for a component host before answering ``::genom::remote_io``.

    Attributes:
        control: Seconds for a description, status, abort or clean; and for a name a host offered
            to be offered again (a host that restarts) before its load is refused (``--zenoh-timeout``).
        stale: Seconds without news of a host (it beats four times within them) after which its ports are not
            served as current and its sends are refused: the network is cut, or the host froze
            (``--zenoh-stale``).
        send: Seconds for a send (a function may take up to the host's function grace to end); a
            gateway gives twice ``control`` plus its function grace (:meth:`with_grace`).
    """

    control: float = setting(5.0, flag="--zenoh-timeout", unit="seconds", refuse=at_least(0.1),
                             help="time a component host has to answer, or to offer again a name it offered, "
                                  "before the gateway answers ::genom::remote_io")
    stale: float = setting(2.0, flag="--zenoh-stale", unit="seconds", refuse=at_least(0.5),
                           help="time without news of a component host after which reads of its ports answer "
                                "::genom::remote_io rather than old data")
    send: float = 10.0

    def with_grace(self, function_grace: float) -> RemoteTimeouts:
        """These timeouts with a send's: twice ``control`` plus *function_grace*."""
        return dataclasses.replace(self, send=2 * self.control + function_grace)
