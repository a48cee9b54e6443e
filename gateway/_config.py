"""The gateway's configuration: the settings groups it composes, from the command line or from code."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import Any

from ..components.core import ClockSettings, HostSettings, SettingsGroup
from ..remote import RemoteTimeouts, ZenohSettings
from ._connection import ConnectionLimits
from ._settings import AccessSettings, LiveViewSettings, RemoteComponents, ServerSettings, SessionLimits

__all__ = ["GatewayConfig"]


def _rig() -> HostSettings:
    # From the gateway, a client names no file unless the operator allowed its directory.
    return HostSettings(audio_files=(), record_dirs=())


@dataclasses.dataclass(frozen=True)
class GatewayConfig:
    """Everything that shapes one gateway: its settings groups, each declared once where it is used.

    Each group declares its settings' defaults, flags, units, help and refusals
    (``aiogenomix.components.core.SettingsGroup``); ``aiogenomix-gateway`` makes its options from
    them, and code builds one with :meth:`of` (``GatewayConfig.of(port=0, token="s3cret")``) or
    from groups (``GatewayConfig(server=ServerSettings(port=0))``).

    Attributes:
        server: Where it listens and what it loads (``--host``, ``--port``, ``--load``, ``--components``).
        access: Who may use it (``--token``, ``--allowed-host``, ``--allow-origin``).
        rig: What the components are told of the rig (``--can``, ``--audio-device``, ``--record-dir``...),
            with the budgets of what clients can make them hold (``--max-port-bytes``...) and the
            settings groups of other packages (``extra``).
        clock: Runtime seconds per real second (``--time-scale``).
        connections: What one connection allows (``--header-timeout``, ``--max-url-bytes``).
        sessions: How many sessions and instances (``--session-idle``, ``--max-sessions``, ``--max-instances``).
        remote: Whether components other processes offer on Zenoh are loaded (``--zenoh``, ``--local``).
        zenoh: Whom the Zenoh session talks to (``--zenoh-connect``, ``--zenoh-listen``...).
        remote_timeouts: How long a component host has to answer (``--zenoh-timeout``, ``--zenoh-stale``).
        view: The live view in Foxglove and Lichtblick (``--foxglove``, ``--max-viewers``...).
    """

    server: ServerSettings = dataclasses.field(default_factory=ServerSettings)
    access: AccessSettings = dataclasses.field(default_factory=AccessSettings)
    rig: HostSettings = dataclasses.field(default_factory=_rig)
    clock: ClockSettings = dataclasses.field(default_factory=ClockSettings)
    connections: ConnectionLimits = dataclasses.field(default_factory=ConnectionLimits)
    sessions: SessionLimits = dataclasses.field(default_factory=SessionLimits)
    remote: RemoteComponents = dataclasses.field(default_factory=RemoteComponents)
    zenoh: ZenohSettings = dataclasses.field(default_factory=ZenohSettings)
    remote_timeouts: RemoteTimeouts = dataclasses.field(default_factory=RemoteTimeouts)
    view: LiveViewSettings = dataclasses.field(default_factory=LiveViewSettings)

    @classmethod
    def of(cls, **settings: Any) -> GatewayConfig:
        """The defaults but for *settings*, each named as in its group: ``of(port=0, token="s3cret", budgets=...)``.

        Raises:
            TypeError: for a name that no group has.
            ValueError: for a value its group refuses (naming the flag).
        """
        config = cls()
        changes: dict[str, dict[str, Any]] = {}
        for name, value in settings.items():
            owner = _OWNERS.get(name)
            if owner is None:
                raise TypeError(f"no settings group of the gateway has {name!r}: the settings are "
                                f"{', '.join(sorted(_OWNERS))}")
            changes.setdefault(owner, {})[name] = value
        return dataclasses.replace(config, **{owner: dataclasses.replace(getattr(config, owner), **values)
                                              for owner, values in changes.items()})

    def groups(self) -> Iterator[SettingsGroup]:
        """Every settings group, in the order of ``--help``: the rig's budgets and other packages' groups included."""
        for field in dataclasses.fields(self):
            group = getattr(self, field.name)
            yield group
            if group is self.rig:
                yield self.rig.budgets
                yield from (extra for extra in self.rig.extra if isinstance(extra, SettingsGroup))

    @property
    def uses_zenoh(self) -> bool:
        """Whether components other processes offer are loaded (``--zenoh``, or any Zenoh setting given)."""
        return self.remote.zenoh or self.zenoh.given()

    def host_settings(self) -> HostSettings:
        """The settings handed to the components: the rig, and the dedicated socket beside the HTTP port.

        The socket binds the gateway's address and asks for its token; the file of ``--audio-device``
        is readable (the operator chose it).
        """
        return dataclasses.replace(self.rig.for_operator(), audio_socket_host=self.server.host,
                                   audio_socket_token=self.access.token)

    def simulated_parts(self) -> list[str]:
        """Plain words for the parts of the rig that are simulated."""
        parts = []
        if self.rig.can == HostSettings().can:
            parts.append("KEMAR drive on a virtual CAN bus")
        if self.rig.audio_device.startswith("sim"):
            parts.append(f"binaural audio scene ({self.rig.audio_device})")
        return parts


def _owners() -> dict[str, str]:
    """Which group of :class:`GatewayConfig` holds each setting's name (each name is in one group)."""
    owners: dict[str, str] = {}
    defaults = GatewayConfig()
    for group in dataclasses.fields(defaults):
        for field in dataclasses.fields(getattr(defaults, group.name)):
            if field.name in owners:  # (at import: a name in two groups is a bug)
                raise TypeError(f"{field.name} is a setting of {owners[field.name]} and of {group.name}")
            owners[field.name] = group.name
    return owners


_OWNERS = _owners()
