"""The settings of a component host: the rig its components drive, and its clock; each declared once.

Both are settings groups (:mod:`._setting_groups`): each setting's default, flag, unit, help and
refusal are declared here, and the gateway and a component host make their options from them.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import TypeVar

from ._budgets import Budgets
from ._setting_groups import SettingsGroup, positive, setting, tcp_port

__all__ = ["HostSettings", "ClockSettings"]

T = TypeVar("T")

_RIG = "rig"
_RIG_ABOUT = "the hardware the components drive, simulated or real, wherever they run"


def _record_mode(text: str) -> int:
    """An octal mode of recordings: ``600``, ``0640``, ``0o644``."""
    digits = text.strip().lower().removeprefix("0o")
    mode = int(digits, 8) if digits.isascii() and digits.isdigit() and set(digits) <= set("01234567") else -1
    if mode < 0 or mode & ~0o666 or mode & 0o600 != 0o600:
        raise argparse.ArgumentTypeError(f"{text!r} is not a recording's mode: octal read and write bits, the "
                                         "owner's both among them (600, 640, 644)")
    return mode


@dataclasses.dataclass(frozen=True)
class ClockSettings(SettingsGroup, section=_RIG, about=_RIG_ABOUT):
    """How the runtime's time runs against real time.

    Attributes:
        time_scale: Runtime seconds per real second (1 on a rig; more to run a simulation faster).
    """

    time_scale: float = setting(1.0, flag="--time-scale", metavar="FACTOR", refuse=positive,
                                help="runtime seconds per real second, for faster simulations")


@dataclasses.dataclass(frozen=True)
class HostSettings(SettingsGroup, section=_RIG, about=_RIG_ABOUT):
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
        extra: The settings of components of other packages, one group per class (a
            :class:`SettingsGroup`, whose flags the gateway and a component host take when the
            package declares it as an ``aiogenomix.settings`` entry point); :meth:`of` finds them by class.
    """

    can: str = setting("virtual", flag="--can", metavar="BUS",
                       help="KEMAR bus: 'virtual' (simulated drive) or INTERFACE:CHANNEL, e.g. socketcan:can0")
    can_timeout: float = setting(0.5, flag="--can-timeout", unit="seconds", refuse=positive,
                                 help="real time the KEMAR drive has to answer a request on the bus")
    audio_device: str = setting("sim", flag="--audio-device", metavar="DEVICE",
                                help="default capture device: sim, sim:SCENE.json, hw:1,0, file:PATH.wav, pa:NAME")
    audio_files: tuple[str, ...] | None = setting(
        None, flag="--audio-files", metavar="DIR", repeatable=True,
        help="a directory clients may name WAV (file:PATH) and scene (sim:PATH) files from (repeatable; "
             "default: none, files are refused)")
    record_dirs: tuple[str, ...] | None = setting(
        None, flag="--record-dir", metavar="DIR", repeatable=True,
        help="a directory the recorder component may write recordings into, and captures may replay them from "
             "(mcap:PATH) (repeatable; default: none, recordings are refused)")
    record_mode: int = setting(0o600, flag="--record-mode", metavar="MODE", parse=_record_mode,
                               help="permissions of new recordings, in octal (default 600: their owner's only, as "
                                    "they hold microphones and cameras; 640 lets the files' group read them)")
    audio_socket_host: str = "127.0.0.1"
    audio_socket_port: int = setting(8081, flag="--audio-socket-port", metavar="PORT", refuse=tcp_port,
                                     help="port of the dedicated audio socket, 0 for a free one")
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
        super().__post_init__()
        mode = self.record_mode
        if isinstance(mode, bool) or not isinstance(mode, int) or mode & ~0o666 or mode & 0o600 != 0o600:
            shown = f"{mode:o}" if isinstance(mode, int) else repr(mode)
            raise ValueError(f"record_mode (--record-mode) has read and write bits only, the owner's both among "
                             f"them (600, 640, 644), not {shown}")
        if not isinstance(self.budgets, Budgets):
            raise TypeError(f"budgets are a Budgets, not {type(self.budgets).__name__}")
        if isinstance(self.extra, list):
            object.__setattr__(self, "extra", tuple(self.extra))

    def for_operator(self) -> HostSettings:
        """These settings as a command line gives them: the file of ``audio_device`` is readable.

        The operator chose that file, so it is readable even when ``--audio-files`` names no directory.
        """
        kind, _, path = self.audio_device.partition(":")
        if kind not in ("file", "sim") or not path:
            return self
        return dataclasses.replace(self, audio_files=(*(self.audio_files or ()), path))
