"""Drive the GenoM3 demo robot and plot ``Mobile.position`` over time (the seed's Figure 4.3, in Python).

python examples/demo_session.py                        # starts a simulated gateway in-process
python examples/demo_session.py --url localhost:8080   # or drive a running gateway
"""

from __future__ import annotations

import argparse
import contextlib
import pathlib
import time

import matplotlib

matplotlib.use("Agg")  # no display needed: the figure goes to a PNG file

import matplotlib.pyplot as plt
from aiogenomix.clients import Module, Request, connect


def record(demo: Module, request: Request, period: float = 0.02) -> tuple[list[float], list[float]]:
    """Sample ``demo.Mobile().position`` every *period* seconds until the request ends.

    Args:
        demo: The demo module.
        request: A request handle (a call made with ``ack=True``).
        period: Seconds between samples.

    Returns:
        The sample times (seconds since the start) and positions (m).
    """
    start = time.monotonic()
    times, positions = [], []
    while True:
        ended = request.done
        times.append(time.monotonic() - start)
        positions.append(demo.Mobile().position)
        if ended:
            break
        request.wait(period)  # returns early when the motion ends
    request.result()  # raises if the motion failed
    return times, positions


def session(url: str, out: pathlib.Path) -> list[tuple[float, float]]:
    """Run the Figure 4.3 session, then a few motions; save the plot to *out*; return (time, position) samples."""
    with connect(url) as genomix1:
        demo = genomix1.load("demo")
        print(f"connected to {genomix1.url} (genomix {genomix1.genomix_version}), session {genomix1.session}")

        # Figure 4.3: a blocking call, a non-blocking one, its status, then a port read.
        demo.GotoPosition(0.5)
        request = demo.GotoPosition(1, ack=True)
        print(f"{request.id}: {request.status}")
        request.wait()
        print(f"{request.id}: {request.status}; Mobile = {demo.Mobile()}")

        # A trajectory: fast to the far end, then slow back by a distance.
        samples: list[tuple[float, float]] = []
        offset = 0.0
        demo.SetSpeed("FAST")
        for start_motion in (lambda: demo.GotoPosition(-1, ack=True), lambda: demo.MoveDistance(0.6, ack=True)):
            times, positions = record(demo, start_motion())
            samples += [(offset + t, p) for t, p in zip(times, positions, strict=True)]
            offset = samples[-1][0]
            demo.SetSpeed("SLOW")
        try:
            demo.GotoPosition(2)
        except demo.TOO_FAR_AWAY as exc:
            print(f"refused: {exc.ex}, overshoot {exc.overshoot} m")

    fig, ax = plt.subplots(figsize=(6, 3))
    ax.plot([t for t, _ in samples], [p for _, p in samples], marker=".")
    ax.set_xlabel("time (s, wall clock)")
    ax.set_ylabel("Mobile.position (m)")
    ax.set_title("demo: GotoPosition(-1) fast, then MoveDistance(0.6) slow")
    ax.grid(True)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    print(f"{len(samples)} samples; plot saved to {out}")
    return samples


def main() -> None:
    """Parse the command line and run the session."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--url", help="a running gateway, host:port (default: start a simulated one here)")
    parser.add_argument("--time-scale", type=float, default=1.0,
                        help="robot seconds per real second of the in-process gateway (default 1)")
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("demo_positions.png"),
                        help="the PNG to write (default demo_positions.png)")
    args = parser.parse_args()
    with contextlib.ExitStack() as stack:
        url = args.url
        if url is None:
            from local_gateway import local_gateway

            url = stack.enter_context(local_gateway(args.time_scale))
        session(url, args.out)


if __name__ == "__main__":
    main()
