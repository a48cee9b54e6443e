"""The settings of a component host: the rig its components drive, one typed value and one default each."""

from __future__ import annotations

import dataclasses
from typing import TypeVar

from ._budgets import Budgets

__all__ = ["HostSettings"]

T = TypeVar("T")


@dataclasses.dataclass(frozen=True)
class HostSettings:
    """What the components of one host are told about the rig: its CAN bus, its sound card, its audio socket.

    Each setting has one default, here; the gateway and a component host fill them from their
    command line (``--can``, ``--can-timeout``, ``--audio-device``, ``--audio-files``,
    ``--record-dir``, ``--record-mode``, ``--audio-socket-port``...).  A component reads them as
    ``self.host.settings.can``.

    Attributes:
        can: The KEMAR head's CAN bus: ``virtual`` (a simulated drive in-process) or
            ``INTERFACE:CHANNEL`` such as ``socketcan:can0``.
        can_timeout: Seconds of real time a drive has to answer a request on the bus.  Real time by
            design (decision 8): bus latency does not follow a sped-up or stepped clock.
        audio_device: The capture device a capture uses when none is named (``sim``, ``hw:1,0``,
            ``file:PATH.wav``...).
        audio_files: The directories clients may name WAV (``file:PATH``) and scene (``sim:PATH``)
            files from; None allows any path (a host built in code, whose author chose its files).
            The gateway passes its ``--audio-files`` and the file of its ``--audio-device``.
        record_dirs: The directories a recorder may write recordings into, and from which captures
            may replay them (``mcap:PATH``); None allows any path (a host built in code, whose author
            chose its files).  The gateway passes its ``--record-dir``: none unless the operator names one.
        record_mode: The permissions of a new recording (``--record-mode``): its owner's only by
            default, since it holds microphones and cameras; read and write bits only, the owner's
            both among them (``0o640`` lets the file's group read it).
        audio_socket_host: The address the dedicated audio socket binds.
        audio_socket_port: The TCP port of the dedicated audio socket (0 picks a free one).
        audio_socket_token: When set, a client of the dedicated socket must first send ``Token <token>``.
        budgets: The bound of every resource a client can make the components hold (ports,
            socket backlogs, blocks, render memory), each with its default and gateway flag.
        extra: The settings of components of other packages, one object per class (a frozen
            dataclass with a default for each setting); :meth:`of` finds them by class.
    """

    can: str = "virtual"
    can_timeout: float = 0.5
    audio_device: str = "sim"
    audio_files: tuple[str, ...] | None = None
    record_dirs: tuple[str, ...] | None = None
    record_mode: int = 0o600
    audio_socket_host: str = "127.0.0.1"
    audio_socket_port: int = 8081
    audio_socket_token: str | None = None
    budgets: Budgets = Budgets()
    extra: tuple[object, ...] = ()

    def of(self, kind: type[T]) -> T:
        """The settings of class *kind* given in :attr:`extra`, or ``kind()``: its defaults."""
        for settings in self.extra:
            if isinstance(settings, kind):
                return settings
        return kind()

    def __post_init__(self) -> None:
        if not self.can_timeout > 0:  # NaN fails this too
            raise ValueError(f"can_timeout must be a positive number of seconds, not {self.can_timeout!r}")
        if not 0 <= self.audio_socket_port <= 65535:
            raise ValueError(f"audio_socket_port must be a TCP port (0 to 65535), not {self.audio_socket_port!r}")
        mode = self.record_mode
        if isinstance(mode, bool) or not isinstance(mode, int) or mode & ~0o666 or mode & 0o600 != 0o600:
            shown = f"{mode:o}" if isinstance(mode, int) else repr(mode)
            raise ValueError(f"record_mode (--record-mode) has read and write bits only, the owner's both among "
                             f"them (600, 640, 644), not {shown}")
        if not isinstance(self.budgets, Budgets):
            raise TypeError(f"budgets are a Budgets, not {type(self.budgets).__name__}")
        # A list given by a caller is kept as a tuple: the settings stay frozen all the way down.
        for name in ("audio_files", "record_dirs"):
            if getattr(self, name) is not None:
                object.__setattr__(self, name, tuple(getattr(self, name)))
