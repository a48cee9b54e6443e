"""Run the simulated KEMAR drive as its own process on a named CAN bus.

Test a real SocketCAN setup without the motor::

    sudo modprobe vcan && sudo ip link add dev vcan0 type vcan && sudo ip link set up vcan0
    python -m aiogenomix.components.kemar.simdrive --interface socketcan --channel vcan0
    aiogenomix-gateway --can socketcan:vcan0
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from collections.abc import Sequence

from ..core import RealClock, ScaledClock

from ._simdrive import DEFAULT_NODE_ID, SimulatedHarmonica

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m aiogenomix.components.kemar.simdrive",
        description="A simulated Elmo Harmonica drive turning a KEMAR head, served on a CAN bus.",
    )
    parser.add_argument("--interface", default="socketcan", help="python-can interface (default: socketcan)")
    parser.add_argument("--channel", default="vcan0", help="bus channel (default: vcan0)")
    parser.add_argument("--node", type=lambda text: int(text, 0), default=DEFAULT_NODE_ID,
                        help="CANopen node id (default: 0x7F)")
    parser.add_argument("--start-azimuth", type=float, default=0.0, help="head azimuth at power-up, degrees")
    parser.add_argument("--limits", type=float, nargs=2, default=(-90.0, 90.0), metavar=("RIGHT", "LEFT"),
                        help="azimuths of the reverse and forward limit switches (default: -90 90)")
    parser.add_argument("--time-scale", type=float, default=1.0,
                        help="run the head this many times faster than real time (default: 1)")
    parser.add_argument("--status-period", type=float, default=1.0,
                        help="seconds between two status lines; 0 for none (default: 1)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Serve the simulated drive until SIGINT or SIGTERM; return the exit status."""
    args = _parser().parse_args(argv)
    clock = RealClock() if args.time_scale == 1.0 else ScaledClock(args.time_scale)
    try:
        drive = SimulatedHarmonica(
            args.channel, interface=args.interface, node_id=args.node, clock=clock,
            start_azimuth=args.start_azimuth, limits=tuple(args.limits),
        )
    except Exception as exc:  # noqa: BLE001 - a CLI reports any start-up failure and exits
        print(f"cannot start the simulated drive on {args.interface}:{args.channel}: {exc}", file=sys.stderr)
        return 1
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    with drive:
        print(f"simulated Harmonica node 0x{args.node:02X} on {args.interface}:{args.channel} "
              f"(limits {args.limits[0]:g}/{args.limits[1]:g} deg, time x{args.time_scale:g}); Ctrl-C stops",
              flush=True)
        while not stop.wait(args.status_period if args.status_period > 0 else None):
            snap = drive.snapshot()
            switches = ("FLS " if snap.forward_limit else "") + ("RLS" if snap.reverse_limit else "")
            print(f"azimuth {snap.azimuth:+8.2f} deg  PX {snap.position:+7d}  "
                  f"speed {snap.velocity / drive.counts_per_degree:+7.1f} deg/s  "
                  f"motor {'on ' if snap.motor_on else 'off'}  UM {snap.unit_mode}  "
                  f"MF 0x{snap.motor_fault:X}  {switches}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
