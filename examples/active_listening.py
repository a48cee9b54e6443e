"""Active listening from outside, as the Two!Ears decision layer drove it: localise, turn the head, combine, face.

The KEMAR (``kemarcapture``: the simulated head and its binaural capture) hears a talker; ``binauloc``
localises it on the audio of ``kemarcapture/Port``. This script is the decision layer, a client of the
gateway through the generated functions: it asks for estimates (``LocalizeSources``, then reads
``Azimuths``: radians in the head frame, with the log-likelihood of every azimuth and the head's
azimuth carried with the audio), turns each into the room frame, adds them up, and turns the head
until front and back are told apart; then it faces the source. The same loop runs inside the
component as ``binauloc.FaceSource``, which the script calls last for comparison.

    .venv/bin/python examples/active_listening.py                      # a simulated gateway in-process
    .venv/bin/python examples/active_listening.py --azimuth 32.5 --plot loop.png
    .venv/bin/python examples/active_listening.py --url localhost:8080 --scene-dir DIR   # a running gateway
                                                                       # (started with --audio-files DIR)
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import math
import pathlib
import tempfile
from collections.abc import Iterator
from typing import Any

import numpy as np

from aiogenomix.clients import Module, connect

#: The neck's limit switches are at ±90°; moves stop 0.5° inside.
LIMIT = 89.5
RATE, CHUNK_MS = 44_100, 50


def write_scene(directory: pathlib.Path, azimuth: float, seed: int = 1, onset: float = 1.2, snr: float = 10.0) -> str:
    """A scene file of one talker at *azimuth* (degrees, room) starting at *onset* s in a diffuse field; its device."""
    path = directory / f"talker-{azimuth:g}.json"
    path.write_text(json.dumps({"seed": seed, "diffuse_level": -snr, "noise_floor": -80, "sources": [
        {"type": "speech", "azimuth": azimuth, "level": -26, "onset": onset}]}))
    return f"sim:{path}"


def in_room(log_likelihood: np.ndarray, head: float) -> np.ndarray:
    """A head-frame log-likelihood on the 1° grid seen from the room, for a head at *head* degrees."""
    grid = np.arange(360.0)
    return np.interp((grid - head) % 360.0, grid, log_likelihood, period=360.0)


def peak_and_mass(log_likelihood: np.ndarray) -> tuple[float, float]:
    """The most likely azimuth (degrees, -180 to 180) and the posterior within ±10° of it."""
    posterior = np.exp(log_likelihood - log_likelihood.max())
    posterior /= posterior.sum()
    best = int(np.argmax(posterior))
    near = np.abs((np.arange(360) - best + 180) % 360 - 180) <= 10
    return (best + 180) % 360 - 180.0, float(posterior[near].sum())


@dataclasses.dataclass
class Loop:
    """What the decision loop heard and did."""

    estimates: list[dict[str, float]] = dataclasses.field(default_factory=list)   # seconds, head, room, confidence
    looks: list[float] = dataclasses.field(default_factory=list)                    # head azimuths looked from
    room: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(360))     # combined log-likelihood
    found: float = math.nan
    confidence: float = 0.0
    facing: float = math.nan


def listen(binauloc: Module, loop: Loop, count: int) -> None:
    """*count* estimates from where the head is now, added to the room's log-likelihood.

    Each call of ``LocalizeSources(1)`` listens from its start: the audio between two calls (a round trip
    to the gateway) goes unheard, as it did for the Two!Ears decision layer reading ``Azimuths``.
    """
    for _ in range(count):
        binauloc.LocalizeSources(1)
        estimate = binauloc.Azimuths()
        head = math.degrees(estimate.headAzimuth)
        loop.room += in_room(np.asarray(estimate.logLikelihood), head)
        loop.estimates.append({"seconds": estimate.frameIndex / RATE, "head": head,
                               "room": math.degrees(estimate.roomAzimuth), "confidence": estimate.confidence})


def decision_loop(head: Module, binauloc: Module, *, turn: float = 30.0, look: int = 6,
                  confidence: float = 0.9, max_turns: int = 4) -> Loop:
    """Localise, turn the head either side of where it started (the source's side first), combine, face."""
    loop = Loop()
    start = head.currentState().position
    loop.looks.append(start)
    listen(binauloc, loop, look)
    first_side = 1.0 if math.sin(math.radians(loop.estimates[-1]["room"] - start)) >= 0 else -1.0
    for turns in range(1, max_turns + 1):
        side = first_side if turns % 2 else -first_side
        target = start + side * turn * ((turns + 1) // 2)
        if abs(target) > LIMIT:
            target = start - side * turn * ((turns + 1) // 2)
        reached = head.MoveAbsolutePosition(target, 60.0).position
        loop.looks.append(reached)
        listen(binauloc, loop, look)
        loop.found, loop.confidence = peak_and_mass(loop.room)
        if loop.confidence >= confidence:
            break
    loop.facing = head.MoveAbsolutePosition(max(-LIMIT, min(LIMIT, loop.found)), 60.0).position
    return loop


def head_path(head: Module) -> tuple[np.ndarray, np.ndarray]:
    """The head's azimuth at the end of every chunk on kemarcapture's port, and the chunk's end in seconds."""
    window = head.Port()
    positions = np.asarray(window.positions)
    held = min(len(positions), int(window.index))
    seconds = (window.index - held + 1 + np.arange(held)) * CHUNK_MS / 1000.0
    return seconds, positions[len(positions) - held:]


@contextlib.contextmanager
def session(url: str | None, scene_dir: pathlib.Path, time_scale: float) -> Iterator[Any]:
    """A client of the gateway at *url*, or of one started here that may read scenes from *scene_dir*."""
    with contextlib.ExitStack() as stack:
        if url is None:
            from local_gateway import local_gateway   # next to this file

            url = stack.enter_context(local_gateway(time_scale, audio_files=[str(scene_dir)]))
        yield stack.enter_context(connect(url))


def run(client: Any, device: str, start: float = 0.0) -> tuple[Loop, dict[str, Any], tuple[np.ndarray, np.ndarray]]:
    """The whole session: home the head, capture the scene, learn the noise, run the loop, then FaceSource."""
    head = client.load("kemarcapture")
    binauloc = client.load("binauloc")
    head.Homing()
    head.MoveAbsolutePosition(start, 200.0)
    binauloc.connect_port("Audio", "kemarcapture/Port")
    binauloc.Setup(RATE, 5000, 1024, 512, "HANNING", 10)
    capturing = head.StartCapture(device, RATE, CHUNK_MS, 400, ack=True)   # 20 s on the port
    binauloc.LearnNoise(1.0)                       # the talker starts after it
    loop = decision_loop(head, binauloc)
    path = head_path(head)
    head.MoveAbsolutePosition(start, 200.0)
    inside = binauloc.FaceSource()                 # the same loop, inside the component
    head.StopCapture()
    capturing.wait()
    return loop, dict(inside), path


def plot(loop: Loop, path: tuple[np.ndarray, np.ndarray], truth: float, out: pathlib.Path) -> None:
    """A polar plot: each estimate in the room (time outwards, darker when surer), the head's path, the source."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")                # the nose's 0° up, positive to the left
    ax.set_theta_direction(1)
    seconds, azimuths = path
    ax.plot(np.radians(azimuths), seconds, color="tab:gray", linewidth=2, label="head (kemarcapture positions)")
    times = np.array([e["seconds"] for e in loop.estimates])
    rooms = np.radians([e["room"] for e in loop.estimates])
    sure = np.array([e["confidence"] for e in loop.estimates])
    ax.scatter(rooms, times, c=sure, cmap="Blues", vmin=0.0, vmax=1.0, edgecolors="tab:blue",
               label="estimates in the room (colour: confidence)")
    top = max(times.max(), seconds.max()) * 1.05
    ax.plot([math.radians(truth)] * 2, [0, top], "--", color="tab:orange", label=f"talker at {truth:g}°")
    ax.plot([math.radians(loop.found)] * 2, [0, top], color="tab:green",
            label=f"found {loop.found:.0f}° ({loop.confidence:.2f})")
    ax.set_rmax(top)
    ax.set_title("Active listening: estimates and the head's path (radius: seconds)")
    ax.legend(loc="lower left", bbox_to_anchor=(-0.1, -0.2), fontsize="small")
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


def main() -> None:
    """Run the session against a gateway (or one started here) and print what both loops found."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", help="a running gateway (default: start a simulated one here)")
    parser.add_argument("--scene-dir", type=pathlib.Path, help="where to write the scene (one of the gateway's "
                                                                "--audio-files directories)")
    parser.add_argument("--azimuth", type=float, default=147.5, help="the talker's room azimuth, degrees")
    parser.add_argument("--time-scale", type=float, default=5.0, help="simulated seconds per real second at most")
    parser.add_argument("--plot", type=pathlib.Path, help="write the polar plot to this PNG file")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        directory = args.scene_dir or pathlib.Path(scratch)
        device = write_scene(directory, args.azimuth)
        with session(args.url, directory, args.time_scale) as client:
            loop, inside, path = run(client, device)
    print(f"talker at {args.azimuth:g} deg; looked from {', '.join(f'{h:.1f}' for h in loop.looks)} deg")
    print(f"decision layer: found {loop.found:.1f} deg (posterior {loop.confidence:.3f}) from "
          f"{len(loop.estimates)} estimates, head now at {loop.facing:.1f} deg")
    print(f"FaceSource:     found {math.degrees(inside['roomAzimuth']):.1f} deg (posterior "
          f"{inside['confidence']:.3f}), {inside['turns']} turn(s), head at {math.degrees(inside['headAzimuth']):.1f}"
          f" deg, {'facing it' if inside['faced'] else 'at its limit'}")
    if args.plot is not None:
        plot(loop, path, args.azimuth, args.plot)
        print(f"plot: {args.plot}")


if __name__ == "__main__":
    main()
