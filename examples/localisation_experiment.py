"""The localisation experiment of docs/localisation.md: a KEMAR in a diffuse field, still head against turning head.

Run it with the project's virtualenv (one core, a minute and a half for the full run)::

    .venv/bin/python examples/localisation_experiment.py            # print the table
    .venv/bin/python examples/localisation_experiment.py --write    # and update the docs and the plot
    .venv/bin/python examples/localisation_experiment.py --azimuths 12 --signals noise   # a quick look
    .venv/bin/python examples/localisation_experiment.py --calibrate   # the localiser's sharpness

``--write`` replaces the results part of ``docs/localisation.md`` and draws
``docs/images/localisation.png``. ``--calibrate`` shows how the confidence
follows the hit rate for several sharpness values, on training cases that the
experiment never uses (other seeds, sources offset by 1.25° from the measured grid).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pathlib
import platform
import re
import sys
import time

# One core, as the figures claim (numpy's FFT is single-threaded; its BLAS might not be).
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from aiogenomix.components.binaural import (  # noqa: E402
    SIGNALS, AzimuthLikelihood, BinauralLocaliser, BinauralRenderer, LocaliserSetup, load_kemar,
)
from aiogenomix.components.binaural.experiment import (  # noqa: E402
    CaseResult, ExperimentConfig, Summary, offset_azimuths, run_experiment, summarise,
)

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "localisation.md"
PLOT = ROOT / "docs" / "images" / "localisation.png"
BEGIN, END = "<!-- results: written by examples/localisation_experiment.py --write -->", "<!-- end of results -->"


def real_time_factors() -> dict[str, float]:
    """Processor-time real-time factors of the renderer and the localiser at both rates."""
    hrirs = load_kemar()
    factors = {}
    for rate in (44_100.0, 24_414.0):
        seconds = 10.0
        dry = np.random.default_rng(1).standard_normal((4, int(seconds * rate)))
        renderer = BinauralRenderer(rate, 4, hrirs=hrirs, diffuse_level=-40.0, sensor_noise=-80.0)
        chunk = 4096
        started = time.process_time()
        ears = np.concatenate([renderer.render(dry[:, s:s + chunk], 0.5 * k, [10.0, 50.0, -70.0, 160.0])
                               for k, s in enumerate(range(0, dry.shape[1], chunk))])
        spent = time.process_time() - started
        factors[f"render {rate:g} Hz (4 sources, diffuse field, head turning)"] = seconds / spent
        localiser = BinauralLocaliser(LocaliserSetup(rate=rate), hrirs=hrirs)
        localiser.learn_noise(ears[:int(rate)])
        started = time.process_time()
        estimates = localiser.feed(ears)
        spent = time.process_time() - started
        factors[f"localise {rate:g} Hz (an estimate every 10 frames of 1024, {len(estimates)} estimates)"] = (
            seconds / spent)
    return factors


def table(summaries: list[Summary]) -> str:
    """The results as a markdown table."""
    lines = ["| signal | SNR | sources | static: lateral median | static: median | static: front/back "
             "| turns between: lateral median | turns between: median | turns between: front/back "
             "| turning: lateral median | turning: median | turning: front/back |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for s in summaries:
        cells = [f"{s.signal}", f"{s.snr:g} dB", f"{s.cases}"]
        for which in ("static", "rotation", "sweep"):
            cells += [f"{getattr(s, which + '_lateral_median'):.2f}°", f"{getattr(s, which + '_median'):.2f}°",
                      f"{100 * getattr(s, which + '_front_back'):.1f} %"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot(results: list[CaseResult], path: pathlib.Path) -> None:
    """Estimated against true azimuth, per signal: still head, turns between estimates, turning while listening."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    signals = list(dict.fromkeys(r.signal for r in results))
    snrs = list(dict.fromkeys(r.snr for r in results))
    figure, axes = plt.subplots(len(signals), 3, figsize=(11, 3.4 * len(signals)), squeeze=False,
                                sharex=True, sharey=True)
    for row, name in enumerate(signals):
        for column, which in enumerate(("static", "rotation", "sweep")):
            ax = axes[row, column]
            ax.plot([-180, 180], [-180, 180], color="0.8", lw=1)
            ax.plot([-180, 0], [0, -180], color="0.9", lw=1, ls="--")     # front/back mirror images
            ax.plot([0, 180], [180, 0], color="0.9", lw=1, ls="--")
            for snr, marker in zip(snrs, ("o", "x", "^", "s"), strict=False):
                chosen = [r for r in results if r.signal == name and r.snr == snr]
                ax.scatter([r.azimuth for r in chosen], [getattr(r, which) for r in chosen], s=14,
                           marker=marker, label=f"{snr:g} dB")
            titles = {"static": "still head", "rotation": "turns between: 0°, +30°, −30°",
                      "sweep": "turning: −30° to +30°"}
            ax.set_title(f"{name}: {titles[which]}", fontsize=10)
            ax.set_xlim(-180, 180)
            ax.set_ylim(-180, 180)
            ax.set_xticks(range(-180, 181, 90))
            ax.set_yticks(range(-180, 181, 90))
            if column == 0:
                ax.set_ylabel("estimated azimuth (°)")
            if row == len(signals) - 1:
                ax.set_xlabel("source azimuth (°)")
    axes[0, 0].legend(loc="upper left", fontsize=8)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90)


def calibrate() -> None:
    """Mean confidence against hit rate (estimate within 10°) for several sharpness values, single estimates."""
    from aiogenomix.components.binaural import _localiser

    rate = 24_414.0
    hrirs = load_kemar()
    setup = LocaliserSetup(rate=rate)
    localiser = BinauralLocaliser(setup, hrirs=hrirs)
    segment = round(0.5 * rate)
    cases = []
    for s_index, name in enumerate(SIGNALS):
        for snr in (20.0, 10.0, 5.0):
            for azimuth in offset_azimuths(24) + 1.25:
                rng = np.random.default_rng([99, s_index, int(snr), int(azimuth * 100) % 100_000])
                head = float(rng.uniform(-10.0, 10.0))
                dry = 0.1 * SIGNALS[name](segment / rate, rate, rng)
                ears = BinauralRenderer(rate, 1, hrirs=hrirs).render(dry[np.newaxis], head, [azimuth])
                field = BinauralRenderer(rate, 0, hrirs=hrirs, diffuse_level=0.0,
                                         seed=int(rng.integers(1 << 30))).render(np.zeros((0, 2 * segment)), 0.0)
                gain = np.sqrt(np.mean(ears**2) / 10 ** (snr / 10))
                localiser.learn_noise(gain * field[:segment])
                estimate = localiser.localise(ears + gain * field[segment:])
                # Undo the sharpness in use: the log-likelihood per unit of sharpness.
                cases.append((estimate.likelihood.log_likelihood / _localiser._SHARPNESS, azimuth - head))
    print("sharpness  mean log p(true ±5°)  mean confidence  hit rate (within 10°)")
    for sharpness in (0.02, 0.05, 0.1, 0.2, 0.5, 1.0):
        scores, confidences, hits = [], [], []
        for values, truth in cases:
            likelihood = AzimuthLikelihood(values * sharpness)
            scores.append(np.log(max(likelihood.mass_near(truth, 5.0), 1e-12)))
            confidences.append(likelihood.confidence())
            hits.append(abs((likelihood.peak() - truth + 180.0) % 360.0 - 180.0) <= 10.0)
        print(f"{sharpness:9g}  {np.mean(scores):20.3f}  {np.mean(confidences):15.3f}  {np.mean(hits):.3f}")


def main(argv: list[str] | None = None) -> int:
    """Run the experiment (or the calibration) and report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--azimuths", type=int, default=72, help="source azimuths round the circle (default 72)")
    parser.add_argument("--signals", nargs="+", default=list(SIGNALS), choices=list(SIGNALS))
    parser.add_argument("--write", action="store_true", help="update docs/localisation.md and the plot")
    parser.add_argument("--calibrate", action="store_true", help="show the localiser's confidence calibration")
    args = parser.parse_args(argv)
    if args.calibrate:
        calibrate()
        return 0
    config = ExperimentConfig(azimuths=tuple(offset_azimuths(args.azimuths)), signals=tuple(args.signals))
    started = time.monotonic()
    results, timing = run_experiment(config, progress=lambda line: print(line, file=sys.stderr, flush=True))
    summaries = summarise(results)
    factors = real_time_factors()
    setup = dataclasses.replace(config.setup, rate=config.rate)
    text = "\n".join([
        f"Measured {time.strftime('%Y-%m-%d')} on {platform.machine()}, Python {platform.python_version()}, "
        f"one core; {args.azimuths} source azimuths, seed {config.seed}, {config.rate:g} Hz, "
        f"{config.segment:g} s per estimate, three estimates per case, head turns ±{config.turn:g}°; "
        f"localiser: frame {setup.frame}, hop {setup.hop}, {setup.min_frequency:g}–{setup.max_frequency:g} Hz "
        f"(run took {time.monotonic() - started:.0f} s).",
        "",
        table(summaries),
        "",
        "Real-time factors (audio seconds per processor second, one core):",
        "",
        *[f"- {name}: {factor:.0f}×" for name, factor in factors.items()],
        f"- within the experiment: rendering {timing.render_factor:.0f}×, localising {timing.localise_factor:.0f}×",
    ])
    print(text)
    if args.write:
        document = DOC.read_text()
        pattern = re.compile(re.escape(BEGIN) + ".*?" + re.escape(END), re.S)
        DOC.write_text(pattern.sub(lambda _: f"{BEGIN}\n{text}\n{END}", document))
        plot(results, PLOT)
        print(f"wrote {DOC.relative_to(ROOT)} and {PLOT.relative_to(ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
