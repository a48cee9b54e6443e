"""How the several-source localiser's parameters were set: on training rooms and seeds, on the KEMAR only.

Run it with the project's virtualenv (one core; about 15 minutes)::

    .venv/bin/python examples/localisation_training.py
    .venv/bin/python examples/localisation_training.py --cases 4      # a quick look

Each training case is drawn as the experiment's are (``binaural.talkers_experiment``: one to three
speech-like talkers on the 5° grid, 1.3 to 1.7 m away, a diffuse noise field) but in other rooms
(``TRAINING_ROOMS``: 16 × 12 × 6 m of RT60 0.45 s and 20 × 14 × 7.5 m of 0.75 s), from other seeds,
and through the KEMAR only: nothing of the experiment's rooms, seeds or second head is used. Each
case is heard for 1 s from a still head and for 1 s with a turn of 20° after 0.5 s (either way,
alternately). For every candidate below, the share of talkers found within 5° (their number given)
and of cases counted right is printed; the defaults of ``GlimpseParameters`` and ``SourceCounting``
are the candidate with the most talkers within 5° with the turn, then counted right.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from aiogenomix.components.binaural import (  # noqa: E402
    GlimpseParameters, LocaliserSetup, RoomAzimuthFilter, SourceCounting, SourceLocaliser, load_kemar,
)
from aiogenomix.components.binaural.talkers_experiment import (  # noqa: E402
    TRAINING_ROOMS, TalkersConfig, TalkerCase, match_talkers, turning_head,
)

#: The seed of the training cases (the experiment's is 31).
SEED = 777

#: The candidates: (name, glimpse parameters, counting rules).
CANDIDATES: list[tuple[str, GlimpseParameters, SourceCounting]] = [
    ("defaults", GlimpseParameters(), SourceCounting()),
    ("sharpness 4", GlimpseParameters(sharpness=4.0), SourceCounting()),
    ("sharpness 16", GlimpseParameters(sharpness=16.0), SourceCounting()),
    ("no coherence weight", GlimpseParameters(coherence_power=0.0), SourceCounting()),
    ("coherence^8", GlimpseParameters(coherence_power=8.0), SourceCounting()),
    ("no onset bonus", GlimpseParameters(onset_gain=0.0), SourceCounting()),
    ("onset bonus x3", GlimpseParameters(onset_gain=3.0), SourceCounting()),
    ("level^0", GlimpseParameters(level_power=0.0), SourceCounting()),
    ("level^0.6", GlimpseParameters(level_power=0.6), SourceCounting()),
    ("count from 3 %", GlimpseParameters(), SourceCounting(min_weight=0.03)),
    ("count from 8 %", GlimpseParameters(), SourceCounting(min_weight=0.08)),
]


def training_cases(config: TalkersConfig, count: int) -> list[dict[str, object]]:
    """The training scenes: still and turning, rendered once and shared by every candidate."""
    kemar = load_kemar()
    rate = config.rate
    cases = []
    for r_index, room in enumerate(TRAINING_ROOMS):
        for talkers in config.talkers:
            for index in range(count):
                case = TalkerCase(config, room, kemar, talkers, (SEED, r_index, talkers, index))
                side = 1.0 if index % 2 else -1.0
                path = turning_head(0.0, 20.0 * side, 0.5, config.turn_speed)
                turning = case.render(1.0 + 20.0 / config.turn_speed, path)[:round(rate)]
                cases.append({"azimuths": case.azimuths, "still": case.render(1.0), "turning": turning,
                              "path": path, "noise": case.noise(0.5)})
            print(f"rendered {room.name}, {talkers} talker(s)", file=sys.stderr, flush=True)
    return cases


def score(config: TalkersConfig, cases: list[dict[str, object]], parameters: GlimpseParameters,
          counting: SourceCounting) -> dict[str, float]:
    """Talkers within 5° and cases counted right, still and turning."""
    localiser = SourceLocaliser(dataclasses.replace(config.setup, rate=config.rate), parameters=parameters,
                                counting=counting)
    found: dict[str, list[float]] = {"still": [], "turning": []}
    counted: dict[str, list[bool]] = {"still": [], "turning": []}
    for case in cases:
        azimuths = np.asarray(case["azimuths"])
        localiser.learn_noise(np.asarray(case["noise"]))
        for which in ("still", "turning"):
            glimpses, centres = localiser.glimpses(np.asarray(case[which]))
            path = case["path"] if which == "turning" else (lambda _t: 0.0)
            heads = np.array([path(c / config.rate) for c in centres])  # type: ignore[operator]
            room = RoomAzimuthFilter(capacity=1000, counting=counting)
            room.add(glimpses, heads)
            errors, _ = match_talkers(list(azimuths), [s.azimuth for s in room.sources(len(azimuths))])
            found[which].extend(errors <= 5.0)
            counted[which].append(len(room.sources()) == len(azimuths))
    return {f"{kind} {which}": float(np.mean(values[which])) for kind, values in (("within 5°", found),
                                                                                    ("counted", counted))
            for which in ("still", "turning")}


def main() -> None:
    """Score every candidate on the training scenes; print a table."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=10, help="cases per room and number of talkers")
    args = parser.parse_args()
    config = TalkersConfig(setup=LocaliserSetup())
    cases = training_cases(config, args.cases)
    print("| candidate | within 5°, still | within 5°, turning | counted, still | counted, turning |")
    print("|---|---:|---:|---:|---:|")
    for name, parameters, counting in CANDIDATES:
        figures = score(config, cases, parameters, counting)
        print(f"| {name} | {100 * figures['within 5° still']:.0f} % | {100 * figures['within 5° turning']:.0f} % "
              f"| {100 * figures['counted still']:.0f} % | {100 * figures['counted turning']:.0f} % |", flush=True)


if __name__ == "__main__":
    main()
