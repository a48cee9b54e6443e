"""Rooms (issue 30): three talkers in a reverberant room, a head turning all the time, on one core.

Each round renders a few seconds of the scene the issue names (a 6 × 4 × 3 m shoebox of RT60 0.5 s,
three speech-like talkers 1.5 to 2.5 m away, the head sweeping ±40° at up to 50°/s) in 50 ms chunks, as
a capture of ``sim`` does, through the measured KEMAR, at 44,100 Hz; then the same with the walls'
absorption given per octave band (seven bands of reflections instead of one); then, for scale, the anechoic
scene of the localisation benchmark (four sources at azimuths, no room), round after round. A figure is
audio seconds per processor second (``time.process_time``), the median over the rounds. Goal: 10× real time.

Then the early part's cost against the reflection order: the processor time of one making of the early
reflections' responses for three talkers afresh (what a head pays every ``update`` seconds when it turns far
enough for an image to change its measurement, or a source moves), and the number of image sources, at
orders 0 to 6.
"""

from __future__ import annotations

import asyncio
import statistics
import time
from typing import Any

import numpy as np

from ._common import Result, verdict

TARGET = 10.0
RATE = 44_100
ORDERS = (0, 1, 2, 3, 4, 5, 6)


def _scene(per_band: bool) -> Any:
    from aiogenomix.components.audio import Scene, Source

    room: dict[str, Any] = {"dimensions": [6.0, 4.0, 3.0]}
    room["rt60"] = [0.7, 0.6, 0.55, 0.5, 0.45, 0.4, 0.35] if per_band else 0.5
    sources = (Source("speech", azimuth=30.0, distance=1.5, level=-26.0),
               Source("speech", azimuth=-80.0, distance=2.0, level=-26.0, voice="female"),
               Source("speech", azimuth=150.0, distance=2.5, level=-26.0, voice="child"))
    return Scene(sources=sources, seed=5, room=room, listener={"x": 3.0, "y": 2.0, "z": 1.5, "facing": 0.0},
                 diffuse_level=-30.0, noise_floor=-80.0)


def _render(seconds: float, rounds: int) -> dict[str, Any]:
    from aiogenomix.components.audio import scene_renderer

    chunk = RATE // 20
    chunks = round(seconds * RATE / chunk)
    heads = 40.0 * np.sin(2 * np.pi * np.arange(1, chunks * rounds + 1) / 100)     # ±40°, up to 50°/s
    from .localisation import _scene as anechoic_scene

    renderers = {"one band": scene_renderer(_scene(False), RATE), "seven bands": scene_renderer(_scene(True), RATE),
                 "anechoic": scene_renderer(anechoic_scene("kemar"), RATE)}
    for renderer in renderers.values():
        renderer.render_float(RATE // 2, 0.0)                                      # the room's start-up
    figures: dict[str, list[float]] = {name: [] for name in renderers}
    for k in range(rounds):
        for name, renderer in renderers.items():
            started = time.process_time()
            for h in heads[k * chunks:(k + 1) * chunks]:
                renderer.render_float(chunk, float(h))
            figures[name].append(seconds / (time.process_time() - started))
    return {name: statistics.median(values) for name, values in figures.items()}


def _early_cost(repeats: int) -> list[dict[str, Any]]:
    from aiogenomix.components.binaural import Pose, RoomRenderer, Shoebox, image_sources, load_kemar

    room = Shoebox.with_rt60((6.0, 4.0, 3.0), 0.5)
    listener = Pose(3.0, 2.0, 1.5)
    talkers = [listener.at(30.0, distance=1.5), listener.at(-80.0, distance=2.0), listener.at(150.0, distance=2.5)]
    rows = []
    for order in ORDERS:
        renderer = RoomRenderer(RATE, 3, hrirs=load_kemar(), room=room, max_order=order, mixing_time=0.25)
        renderer.render(np.zeros((3, 64)), 0.0, talkers, listener.position)
        assert renderer.early is not None
        positions, centre = np.asarray(talkers), np.asarray(listener.position)
        times = []
        for r in range(repeats):
            started = time.process_time()
            renderer.early.spectra(positions, centre, float(r))     # made afresh, as after a move
            times.append(time.process_time() - started)
        images = sum(len(image_sources(room, t, listener.position, max_order=order, max_time=0.25).orders) - 1
                     for t in talkers)
        rows.append({"order": order, "images": images, "ms": 1000 * statistics.median(times)})
    return rows


async def run(seconds: float = 4.0, rounds: int = 15, repeats: int = 9) -> Result:
    """Real-time factors and the early part's cost per order (in a thread: the benchmark's loop stays free)."""
    factors = await asyncio.to_thread(_render, seconds, rounds)
    early = await asyncio.to_thread(_early_cost, repeats)
    return {"real_time_factor": factors, "rounds": rounds, "seconds_per_round": seconds, "target": TARGET,
            "verdict": {name: verdict(value, TARGET, lower_is_better=False) for name, value in factors.items()
                        if name != "anechoic"},
            "early": early}


def render(result: Result) -> str:
    """The section of docs/benchmarks.md."""
    rtf = result["real_time_factor"]
    lines = ["## Rooms: three talkers in a reverberant room (issue 30)", "",
             f"One process, one core's worth of processor time. Each round renders {result['seconds_per_round']:g} s "
             "of three speech-like talkers 1.5, 2 and 2.5 m away in a 6 × 4 × 3 m room of RT60 0.5 s (image sources "
             "to order 3 through the measured KEMAR, then the diffuse tail), a diffuse noise field and sensor noise, "
             "at 44,100 Hz in 50 ms chunks, the head sweeping ±40° at up to 50°/s (the early reflections looked up "
             "every 50 ms, and made again, all talkers in one weighted count, whenever an image is heard through "
             "another measurement: at this speed, every time; only the responses holding such an image are "
             "transformed again, about three quarters of them). The same room with its RT60 given per octave band "
             "has reflections whose band gains take three shapes (one per order), so three responses a talker "
             "instead of one, each image counted into its order's; the talkers share one late tail (decision 44). "
             "The anechoic scene of four sources at "
             "azimuths (the localisation benchmark's) alternates with them, for scale. Median over the rounds of "
             "audio seconds per processor second; goal: 10× real time.", "",
             "| scene | rounds | real time factor | of the anechoic scene's | verdict |", "|---|---:|---:|---:|---|"]
    names = {"one band": "room, one RT60", "seven bands": "room, RT60 per octave band",
             "anechoic": "anechoic, four sources"}
    for name, value in rtf.items():
        lines.append(f"| {names[name]} | {result['rounds']} | {value:.1f}× | {value / rtf['anechoic']:.2f} | "
                     f"{result['verdict'].get(name, '')} |")
    lines += ["", "The early part's cost against the reflection order: one making of the early reflections of the "
              "three talkers (image sources within 250 ms, each through its nearest measured HRIR), as a turning "
              "head pays it every 50 ms. Order 0 is the fixed part: the FFT of responses of 250 ms (the mixing time "
              "is held there for the comparison; by default it is the next order's first arrival, 26 ms here). The "
              "images' taps are one weighted count (linear in the images), then one FFT a talker and ear (fixed): "
              "made afresh here, every response transformed.",
              "",
              "| order | image sources | milliseconds |", "|---:|---:|---:|"]
    for row in result["early"]:
        lines.append(f"| {row['order']} | {row['images']} | {row['ms']:.2f} |")
    lines.append("")
    return "\n".join(lines)
