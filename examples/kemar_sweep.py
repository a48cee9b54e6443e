"""Home the KEMAR head, then sweep it left and right while printing ``currentState``.

Start a gateway first (the simulated drive is the default bus)::

    aiogenomix-gateway --can virtual            # or --can socketcan:can0 on the rig
    python examples/kemar_sweep.py --amplitude 60 --sweeps 2

Positive azimuths are to the left (towards the forward limit switch).
"""

from __future__ import annotations

import argparse
import sys
import time

from aiogenomix.clients import GenomixError, connect


def print_state(state: object, started: float) -> None:
    """Print one ``kemar::state`` reading."""
    print(f"{time.monotonic() - started:7.2f} s  position {state.position:+7.2f} deg  "  # type: ignore[attr-defined]
          f"speed {state.speed:+7.1f} deg/s  "  # type: ignore[attr-defined]
          f"limits [{state.maxRight:+.1f}, {state.maxLeft:+.1f}]", flush=True)  # type: ignore[attr-defined]


def main() -> int:
    """Home, sweep, print; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--address", default="localhost:8080", help="the gateway (default localhost:8080)")
    parser.add_argument("--amplitude", type=float, default=60.0, help="sweep between -A and +A degrees (default 60)")
    parser.add_argument("--speed", type=float, default=100.0, help="head speed in deg/s (default 100)")
    parser.add_argument("--sweeps", type=int, default=2, help="number of left-right sweeps (default 2)")
    parser.add_argument("--period", type=float, default=0.1, help="seconds between two prints (default 0.1)")
    args = parser.parse_args()

    started = time.monotonic()
    try:
        with connect(args.address) as gateway:
            kemar = gateway.load("kemar")
            print("homing: finding both limit switches ...", flush=True)
            kemar.Homing()
            print_state(kemar.currentState(), started)
            kemar.SetVelocity(args.speed)
            targets = [args.amplitude, -args.amplitude] * args.sweeps + [0.0]
            for target in targets:
                print(f"--> MoveAbsolutePosition({target:+.1f})", flush=True)
                move = kemar.MoveAbsolutePosition(target, ack=True)  # returns at once
                while not move.wait(args.period):
                    print_state(kemar.currentState(), started)
                move.result()  # raises if the move ended in error
                print_state(kemar.currentState(), started)
    except GenomixError as exc:
        print(f"kemar_sweep: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"kemar_sweep: cannot reach the gateway at {args.address}: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
