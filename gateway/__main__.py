"""Command line of the gateway: ``aiogenomix-gateway`` / ``python -m aiogenomix.gateway``."""

from __future__ import annotations

import argparse
import logging
import os
import sys

from ._config import GatewayConfig
from ._run import run

__all__ = ["main", "parse_args"]


def parse_args(argv: list[str] | None = None) -> GatewayConfig:
    """Turn command-line arguments into a :class:`GatewayConfig`."""
    defaults = GatewayConfig()
    parser = argparse.ArgumentParser(
        prog="aiogenomix-gateway",
        description="A genomix-compatible HTTP/JSON gateway hosting the Two!Ears components.",
    )
    parser.add_argument("--host", default=defaults.host, help="address to bind (default %(default)s)")
    parser.add_argument("--port", type=int, default=defaults.port,
                        help="HTTP port, 0 for a free one (default %(default)s)")
    parser.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    parser.add_argument("--can", default=defaults.can,
                        help="KEMAR bus: 'virtual' (simulated drive) or INTERFACE:CHANNEL, e.g. socketcan:can0")
    parser.add_argument("--audio-device", default=defaults.audio_device,
                        help="default capture device: sim, sim:SCENE.json, hw:1,0, file:PATH.wav (default %(default)s)")
    parser.add_argument("--audio-socket-port", type=int, default=defaults.audio_socket_port,
                        help="port of the dedicated audio socket, 0 for a free one (default %(default)s)")
    parser.add_argument("--time-scale", type=float, default=defaults.time_scale,
                        help="runtime seconds per real second, for faster simulations (default %(default)s)")
    parser.add_argument("--load", action="append", default=[], metavar="NAME[:ARGS]",
                        help="load a component at start (repeatable), e.g. demo or demo:-i demo2")
    parser.add_argument("--components", help="comma-separated allow-list of loadable components")
    parser.add_argument("--token", default=os.environ.get("AIOGENOMIX_TOKEN"),
                        help="require 'Authorization: Bearer TOKEN' (default: $AIOGENOMIX_TOKEN, unset = open)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    return GatewayConfig(
        host=args.host, port=args.port, time_scale=args.time_scale, can=args.can,
        audio_device=args.audio_device, audio_socket_port=args.audio_socket_port, token=args.token or None,
        components=args.components.split(",") if args.components else None, preload=args.load,
    )


def main(argv: list[str] | None = None) -> int:
    """Run the gateway until SIGINT/SIGTERM; return the exit status."""
    run(parse_args(argv))
    return 0


if __name__ == "__main__":
    sys.exit(main())
