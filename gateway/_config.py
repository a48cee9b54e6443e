"""The gateway's configuration, from the command line or from code."""

from __future__ import annotations

import dataclasses

from ..components.core import Budgets, HostSettings
from ..components.core.runtime import MIB, rig_settings

__all__ = ["GatewayConfig"]

#: The rig's defaults: each setting has one, in HostSettings.
_RIG = HostSettings()


@dataclasses.dataclass
class GatewayConfig:
    """Everything that shapes one gateway.

    Attributes:
        host: Address to bind (``127.0.0.1``: reachable from this machine only).
        port: HTTP port (0 picks a free one).
        time_scale: Runtime seconds per real second (1 on a rig; more to run a simulation faster).
        can: The CAN bus of the KEMAR head: ``virtual`` (a simulated drive in-process) or
            ``<interface>:<channel>`` such as ``socketcan:can0``.
        can_timeout: Seconds of real time the drive has to answer a request on the bus.
        audio_device: Default capture device shown by ``StartCapture`` (``sim``, ``hw:1,0``...).
        audio_socket_port: TCP port of the dedicated audio socket (0 picks a free one).
        audio_files: Directories from which clients may name WAV files (``file:PATH``) and scene
            files (``sim:PATH``); none by default, so a client cannot make the gateway read its disk.
            The file of ``audio_device`` itself is always allowed: the operator chose it.
        record_dirs: Directories a ``recorder`` may write recordings into, and captures may replay
            them from (``mcap:PATH``); none by default, so a client cannot make the gateway write its disk.
        record_mode: The permissions of new recordings (``0o600``: their owner's only).
        token: When set, every request must carry ``Authorization: Bearer <token>``.
        allowed_hosts: Host names browsers may use for the gateway besides IP addresses,
            ``localhost`` and this machine's names (DNS-rebinding protection; ``*``: any).
        allowed_origins: Web origins whose pages may use the gateway (cross-site protection).
        components: When set, only these components can be loaded.
        preload: Components loaded at start, as ``name`` or ``name:-i instance``.
        ping_interval: Seconds between keep-alive comments on idle event streams.
        function_grace: How long a ``send`` waits for a function to end before replying ``sent``.
        header_timeout: Seconds a client has to send a request's line and headers (408 after).
        max_url_bytes: The longest request line accepted, in bytes (414 beyond; at least 8192).
        keep_alive: Seconds an idle kept-alive HTTP connection stays open.
        session_idle: Seconds after which a session that nobody listens to is forgotten.
        max_sessions: How many sessions may exist at once (429 for a new one beyond).
        max_instances: How many component instances may be loaded at once (429 beyond).
        budgets: The bounds of what clients can make the components hold: audio ports, dedicated-socket
            clients and their unsent replies, ``basc`` blocks, worlds' render memory (``--max-port-bytes``...).
        zenoh: Load components that other processes offer on Zenoh (``aiogenomix-component``); every
            name then runs where a component host offers it, except the ``zenoh_local`` ones.
        zenoh_connect: Zenoh endpoints to connect to (``tcp/HOST:PORT``): the gateway talks to these
            and to nobody else (no scouting, no gossip).
        zenoh_listen: Zenoh endpoints to listen on (none by default: hosts do not connect to a gateway).
        zenoh_config: Zenoh's own configuration file (JSON5: TLS, user/password, access control, a
            router); ``zenoh_connect`` and ``zenoh_listen`` replace its endpoints.
        zenoh_scout: Find hosts by multicast scouting and gossip, listening on every interface.
        zenoh_local: Component names that run in the gateway even with ``zenoh`` (an explicit choice:
            a host that restarts can never be replaced by a copy in the gateway).
        foxglove_port: Serve the live view in Foxglove and Lichtblick on this TCP port (None: no view; 0: a free
            port).  It admits viewers as the gateway admits requests: Host, Origin and token (decision 0036).
        foxglove_host: The address the live view binds (the loopback address unless the operator says so).
        max_viewers: How many viewers of the live view may be connected at once (429 for one more).
        viewer_bytes: The most bytes one viewer may hold unsent; a viewer past it is dropped.
        zenoh_timeout: Seconds a component host has to answer a query (a send gets twice that plus
            ``function_grace``), and to offer again a name it offered, before the gateway answers
            ``::genom::remote_io``.
        zenoh_stale: Seconds without news of a component host after which reads of its ports answer
            ``::genom::remote_io`` and sends to it are refused (hosts beat four times within it).
    """

    host: str = "127.0.0.1"
    port: int = 8080
    time_scale: float = 1.0
    can: str = _RIG.can
    can_timeout: float = _RIG.can_timeout
    audio_device: str = _RIG.audio_device
    audio_socket_port: int = _RIG.audio_socket_port
    audio_files: list[str] = dataclasses.field(default_factory=list)
    record_dirs: list[str] = dataclasses.field(default_factory=list)
    record_mode: int = _RIG.record_mode
    token: str | None = None
    allowed_hosts: list[str] = dataclasses.field(default_factory=list)
    allowed_origins: list[str] = dataclasses.field(default_factory=list)
    components: list[str] | None = None
    preload: list[str] = dataclasses.field(default_factory=list)
    ping_interval: float = 15.0
    function_grace: float = 2.0
    header_timeout: float = 10.0
    max_url_bytes: int = 65536
    keep_alive: float = 75.0
    session_idle: float = 600.0
    max_sessions: int = 256
    max_instances: int = 64
    budgets: Budgets = dataclasses.field(default_factory=Budgets)
    zenoh: bool = False
    zenoh_connect: list[str] = dataclasses.field(default_factory=list)
    zenoh_listen: list[str] = dataclasses.field(default_factory=list)
    zenoh_config: str | None = None
    zenoh_scout: bool = False
    zenoh_local: list[str] = dataclasses.field(default_factory=list)
    zenoh_timeout: float = 5.0
    zenoh_stale: float = 2.0
    foxglove_port: int | None = None
    foxglove_host: str = "127.0.0.1"
    max_viewers: int = 8
    viewer_bytes: int = 32 * MIB

    def check(self) -> None:
        """Refuse settings that contradict each other.

        Raises:
            ValueError: saying which flag to add or change.
        """
        if self.foxglove_port is not None and not 0 <= self.foxglove_port <= 65535:
            raise ValueError(f"--foxglove takes a TCP port (0 to 65535), not {self.foxglove_port}")
        if self.max_viewers < 1 or self.viewer_bytes < 1:
            raise ValueError("--max-viewers and --max-viewer-bytes take a whole number, 1 or more")

    def host_settings(self) -> HostSettings:
        """The settings handed to the components: the rig, and the dedicated socket beside the HTTP port."""
        return rig_settings(can=self.can, can_timeout=self.can_timeout, audio_device=self.audio_device,
                            audio_socket_port=self.audio_socket_port, audio_socket_host=self.host,
                            audio_socket_token=self.token, audio_files=self.audio_files, budgets=self.budgets,
                            record_dirs=self.record_dirs, record_mode=self.record_mode)

    def simulated_parts(self) -> list[str]:
        """Plain words for the parts of the rig that are simulated."""
        parts = []
        if self.can == _RIG.can:
            parts.append("KEMAR drive on a virtual CAN bus")
        if self.audio_device.startswith("sim"):
            parts.append(f"binaural audio scene ({self.audio_device})")
        return parts
