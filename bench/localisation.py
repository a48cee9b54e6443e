"""Binaural rendering and localisation (issues 25 and 31): real-time factors on one core, in alternating blocks.

Each round renders a block of a simulated scene (the capture's path: sources through the measured
KEMAR HRIRs, the diffuse field, sensor noise, the head turning all the time) and localises it with the
dominant-source localiser of issue 25 (fed with the head azimuth of every sample), then renders the
same block with the spherical head for comparison, then localises a block of three talkers in a
reverberant room (rendered once beforehand) with the several-source localiser ``binauloc`` runs (issue
31: glimpses, the room filter, the sources counted); the four alternate round after round, so that all
see the same machine. A figure is audio seconds per processor second (``time.process_time``: every
thread of the process counts, so it is a one-core figure however many threads a library starts), the
median over the rounds. Goal: at least 10× real time for rendering and for localising, at 44,100 Hz
and at the Two!Ears scripts' 24,414 Hz.
"""

from __future__ import annotations

import asyncio
import statistics
import time
from typing import Any

import numpy as np

from ._common import Result, verdict

TARGET = 10.0
RATES = (44_100, 24_414)
SOURCES = 4


def _scene(head: str) -> Any:
    from aiogenomix.components.audio import Scene, Source

    sources = (Source("speech", azimuth=30.0, level=-26.0), Source("noise", azimuth=-60.0, level=-30.0),
               Source("tone", azimuth=120.0, level=-30.0, frequency=500.0),
               Source("clicks", azimuth=170.0, level=-12.0))
    return Scene(sources=sources[:SOURCES], seed=5, head=head,  # type: ignore[arg-type]
                 diffuse_level=-20.0 if head == "kemar" else None, noise_floor=-80.0)


def _talkers(rate: int, seconds: float) -> Any:
    """Three speech-like talkers in an 8 x 6 x 3.2 m room of RT60 0.6 s, the head turning ±20°: ``(frames, 2)``."""
    from aiogenomix.components.binaural import Pose, Shoebox, Talker, render_scene, speech_like

    listener = Pose(4.2, 2.8, 1.5)
    talkers = [Talker(speech_like(seconds, rate, np.random.default_rng(k), voice), listener.at(azimuth, distance=1.6),
                      level=-20.0) for k, (azimuth, voice) in enumerate(((35.0, "male"), (-80.0, "female"),
                                                                          (150.0, "child")))]
    return render_scene(talkers, listener, rate=rate, seconds=seconds, room=Shoebox.with_rt60((8.0, 6.0, 3.2), 0.6),
                        head=lambda t: 20.0 * np.sin(2 * np.pi * t / 4.0), diffuse_level=-50.0, sensor_noise=-70.0)


def _measure(rate: int, seconds: float, rounds: int) -> dict[str, Any]:
    from aiogenomix.components.audio import scene_renderer
    from aiogenomix.components.binaural import BinauralLocaliser, LocaliserSetup, SourceLocaliser

    chunk = rate // 20                                           # 50 ms chunks, as capture's default
    chunks = round(seconds * rate / chunk)
    heads = 40.0 * np.sin(2 * np.pi * np.arange(1, chunks * rounds + 1) / 200)   # always turning, ±40°
    kemar = scene_renderer(_scene("kemar"), rate)
    sphere = scene_renderer(_scene("spherical"), rate)
    localiser = BinauralLocaliser(LocaliserSetup(rate=float(rate)))
    localiser.learn_noise(kemar.render_float(rate, 0.0))
    several = SourceLocaliser(LocaliserSetup(rate=float(rate)))
    talkers = _talkers(rate, seconds)
    talker_heads = 20.0 * np.sin(2 * np.pi * np.arange(1, len(talkers) + 1) / rate / 4.0)
    several.learn_noise(0.01 * np.random.default_rng(2).standard_normal((rate // 2, 2)))
    figures: dict[str, list[float]] = {"render": [], "localise": [], "spherical": [], "several": []}
    estimates = 0
    for k in range(rounds):
        turn = heads[k * chunks:(k + 1) * chunks]
        started = time.process_time()
        ears = np.concatenate([kemar.render_float(chunk, float(h)) for h in turn])
        figures["render"].append(seconds / (time.process_time() - started))
        per_sample = np.repeat(turn, chunk)
        started = time.process_time()
        for at in range(0, len(ears), chunk):
            estimates += len(localiser.feed(ears[at:at + chunk], per_sample[at:at + chunk]))
        figures["localise"].append(seconds / (time.process_time() - started))
        started = time.process_time()
        for h in turn:
            sphere.render_float(chunk, float(h))
        figures["spherical"].append(seconds / (time.process_time() - started))
        several.reset_stream()
        started = time.process_time()
        for at in range(0, len(talkers), chunk):
            several.feed(talkers[at:at + chunk], talker_heads[at:at + chunk])
        figures["several"].append(seconds / (time.process_time() - started))
    medians = {name: statistics.median(values) for name, values in figures.items()}
    return {"real_time_factor": medians, "rounds": rounds, "seconds_per_round": seconds, "estimates": estimates,
            "verdict": {name: verdict(medians[name], TARGET, lower_is_better=False)
                        for name in ("render", "localise", "several")}}


async def run(seconds: float = 5.0, rounds: int = 7) -> Result:
    """Real-time factors at both rates (in a thread: the benchmark's loop stays free)."""
    rates = {}
    for rate in RATES:
        rates[str(rate)] = await asyncio.to_thread(_measure, rate, seconds, rounds)
    return {"rates": rates, "sources": SOURCES, "target": TARGET}


def render(result: Result) -> str:
    """The section of docs/benchmarks.md."""
    seconds = result["rates"]["44100"]["seconds_per_round"]
    lines = ["## Binaural rendering and localisation (issues 25 and 31)", "",
             f"One process, one core's worth of processor time. Each round renders {seconds:g} s "
             f"of a scene of {result['sources']} sources (speech-like, noise, a tone, clicks) with a diffuse field and "
             "sensor noise through the measured KEMAR HRIRs, in 50 ms chunks with the head turning all the time (the "
             "simulated capture's path); localises it as `binauloc` does (the streaming localiser, 1024-sample frames "
             "every 512, an estimate every 10 frames, the head azimuth of every sample); and renders the same with "
             "the spherical head; and localises as many seconds of three speech-like talkers in a room of RT60 0.6 s "
             "(rendered beforehand, the head turning ±20°) with the several-source localiser `binauloc` runs now "
             "(glimpses, the room filter, the talkers counted, an estimate every 10 frames). The four alternate, "
             "round after round; the figure is the median over the rounds of audio seconds per processor second. "
             "Goal: 10× real time or more for rendering and for localising (issue 31: three talkers at 24,414 Hz).",
             "", "| rate | rounds | render (KEMAR) | localise (dominant source) | render (spherical head) "
             "| localise three talkers | verdicts |",
             "|---:|---:|---:|---:|---:|---:|---|"]
    for rate, figures in result["rates"].items():
        rtf = figures["real_time_factor"]
        lines.append(f"| {int(rate):,} Hz | {figures['rounds']} | {rtf['render']:.0f}× | {rtf['localise']:.0f}× | "
                     f"{rtf['spherical']:.0f}× | {rtf['several']:.0f}× | render {figures['verdict']['render']}, "
                     f"localise {figures['verdict']['localise']}, three talkers {figures['verdict']['several']} |")
    lines.append("")
    return "\n".join(lines)
