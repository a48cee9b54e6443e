"""The command-line options of the simulated or real rig, shared by the gateway and a component host."""

from __future__ import annotations

import argparse

from ._budgets import Budgets
from ._settings import HostSettings

__all__ = ["add_rig_arguments", "rig_settings"]

#: Each setting's one default.
_DEFAULTS = HostSettings()


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:  # NaN too
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, not {text}")
    return value


def _record_mode(text: str) -> int:
    """An octal mode of recordings: ``600``, ``0640``, ``0o644``."""
    digits = text.strip().lower().removeprefix("0o")
    try:
        mode = int(digits, 8) if digits.isascii() and digits.isdigit() else -1
    except ValueError:
        mode = -1
    if mode < 0 or mode & ~0o666 or mode & 0o600 != 0o600:
        raise argparse.ArgumentTypeError(f"{text!r} is not a recording's mode: octal read and write bits, the "
                                         "owner's both among them (600, 640, 644)")
    return mode


def add_rig_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of the components' hardware and clock to *parser*, wherever they run.

    They are ``--log-level``, ``--can``, ``--can-timeout``, ``--audio-device``, ``--audio-socket-port``,
    ``--audio-files``, ``--record-dir``, ``--record-mode`` and ``--time-scale``, with the defaults of
    :class:`HostSettings`.
    """
    parser.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    parser.add_argument("--can", default=_DEFAULTS.can,
                        help="KEMAR bus: 'virtual' (simulated drive) or INTERFACE:CHANNEL, e.g. socketcan:can0")
    parser.add_argument("--can-timeout", type=_positive, default=_DEFAULTS.can_timeout, metavar="SECONDS",
                        help="real time the KEMAR drive has to answer a request on the bus (default %(default)s)")
    parser.add_argument("--audio-device", default=_DEFAULTS.audio_device,
                        help="default capture device: sim, sim:SCENE.json, hw:1,0, file:PATH.wav (default %(default)s)")
    parser.add_argument("--audio-socket-port", type=int, default=_DEFAULTS.audio_socket_port,
                        help="port of the dedicated audio socket, 0 for a free one (default %(default)s)")
    parser.add_argument("--audio-files", action="append", default=[], metavar="DIR",
                        help="a directory clients may name WAV (file:PATH) and scene (sim:PATH) files from "
                             "(repeatable; default: none, files are refused)")
    parser.add_argument("--record-dir", action="append", default=[], metavar="DIR",
                        help="a directory the recorder component may write recordings into, and captures may "
                             "replay them from (mcap:PATH) (repeatable; default: none, recordings are refused)")
    parser.add_argument("--record-mode", type=_record_mode, default=_DEFAULTS.record_mode, metavar="MODE",
                        help="permissions of new recordings, in octal (default 600: their owner's only, as they "
                             "hold microphones and cameras; 640 lets the files' group read them)")
    parser.add_argument("--time-scale", type=float, default=1.0,
                        help="runtime seconds per real second, for faster simulations (default %(default)s)")


def rig_settings(*, can: str, can_timeout: float, audio_device: str, audio_socket_port: int,
                 audio_socket_host: str, audio_socket_token: str | None, audio_files: list[str],
                 record_dirs: list[str] | None = None, record_mode: int = _DEFAULTS.record_mode,
                 budgets: Budgets | None = None) -> HostSettings:
    """The settings of a rig given on a command line (the file of ``--audio-device`` is always allowed).

    The operator chose that file, so it is readable even when ``--audio-files`` names no directory.
    """
    kind, _, path = audio_device.partition(":")
    operator_file = [path] if kind in ("file", "sim") and path else []
    return HostSettings(can=can, can_timeout=can_timeout, audio_device=audio_device,
                        audio_socket_port=audio_socket_port, audio_socket_host=audio_socket_host,
                        audio_socket_token=audio_socket_token, audio_files=(*audio_files, *operator_file),
                        record_dirs=tuple(record_dirs or ()), record_mode=record_mode, budgets=budgets or Budgets())
