"""The command-line options of the simulated or real rig, shared by the gateway and a component host."""

from __future__ import annotations

import argparse

from ._config import GatewayConfig

__all__ = ["add_rig_arguments"]


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:  # NaN too
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, not {text}")
    return value


def add_rig_arguments(parser: argparse.ArgumentParser, defaults: GatewayConfig) -> None:
    """Add the options of the components' hardware and clock to *parser*, wherever they run.

    They are ``--log-level``, ``--can``, ``--can-timeout``, ``--audio-device``, ``--audio-socket-port``,
    ``--audio-files``, ``--record-dir`` and ``--time-scale``, with *defaults* from the gateway's configuration.
    """
    parser.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    parser.add_argument("--can", default=defaults.can,
                        help="KEMAR bus: 'virtual' (simulated drive) or INTERFACE:CHANNEL, e.g. socketcan:can0")
    parser.add_argument("--can-timeout", type=_positive, default=defaults.can_timeout, metavar="SECONDS",
                        help="real time the KEMAR drive has to answer a request on the bus (default %(default)s)")
    parser.add_argument("--audio-device", default=defaults.audio_device,
                        help="default capture device: sim, sim:SCENE.json, hw:1,0, file:PATH.wav (default %(default)s)")
    parser.add_argument("--audio-socket-port", type=int, default=defaults.audio_socket_port,
                        help="port of the dedicated audio socket, 0 for a free one (default %(default)s)")
    parser.add_argument("--audio-files", action="append", default=[], metavar="DIR",
                        help="a directory clients may name WAV (file:PATH) and scene (sim:PATH) files from "
                             "(repeatable; default: none, files are refused)")
    parser.add_argument("--record-dir", action="append", default=[], metavar="DIR",
                        help="a directory the recorder component may write recordings into, and captures may "
                             "replay them from (mcap:PATH) (repeatable; default: none, recordings are refused)")
    parser.add_argument("--time-scale", type=float, default=defaults.time_scale,
                        help="runtime seconds per real second, for faster simulations (default %(default)s)")
