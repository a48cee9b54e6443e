"""How the several-source localiser's parameters were set: on training rooms, seeds and heads, never the experiment's.

Run it with the project's virtualenv (one core; about 5 minutes)::

    .venv/bin/python examples/localisation_training.py
    .venv/bin/python examples/localisation_training.py --cases 3      # a quick look
    .venv/bin/python examples/localisation_training.py --turns --jobs 2   # the planner's largest turn (5 min)
    .venv/bin/python examples/localisation_training.py --looks --jobs 2   # how long each look lasts (4 min)

Each training case is drawn as the experiment's are (``binaural.talkers_experiment``: one to three
speech-like talkers on the 5° grid, 1.3 to 1.7 m away, a diffuse noise field) but in other rooms
(``TRAINING_ROOMS``: 16 × 12 × 6 m of RT60 0.45 s and 20 × 14 × 7.5 m of 0.75 s), from other seeds, and
heard by two training heads: the MIT KEMAR (the templates' own) and a **spherical head**
(:func:`~aiogenomix.components.audio.sphere_hrirs`: Brown & Duda's model, ears on the interaural axis,
no torso, no pinnae, front and back alike), a head the templates never saw that is not the experiment's
snowman (which nothing here uses). Each case is heard for 1 s from a still head and for 1 s with a turn
of 30° after 0.5 s (either way, alternately), the turning head's units fed to a room filter that keeps
``front_back_weight`` of the templates' front/back preference
(:func:`~aiogenomix.components.binaural.tempered`).

For every candidate, the share of talkers found within 5° (their number given), of front/back
confusions and of cases counted right is printed per head. The defaults of ``GlimpseParameters``
and ``SourceCounting`` are the candidate with the most talkers within 5° on the KEMAR (still and
turning); ``TURNING_FRONT_BACK_WEIGHT`` is the front/back weight with the most talkers within 5°
on the spherical head with a turn that keeps the KEMAR's within 3 points of its best.

``--turns`` runs the experiment's own ``filter`` strategy (looks of ``TalkersConfig.look``, a planned turn
after each, 1 s of audio in all) in the training rooms on both training heads, for each largest turn the
planner may take (:data:`LARGEST_TURNS`); the experiment's ``TalkersConfig.max_turn`` is the one with the
most talkers within 5° over both heads. ``--looks`` does the same for how long each look lasts before the
next turn is planned (:data:`LOOKS`; ``TalkersConfig.look``).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import os
import sys
from typing import Any

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402
import numpy.typing as npt  # noqa: E402

from aiogenomix.components.audio import sphere_hrirs  # noqa: E402
from aiogenomix.components.binaural import (  # noqa: E402
    TURNING_FRONT_BACK_WEIGHT, GlimpseParameters, RoomAzimuthFilter, SourceCounting, SourceLocaliser,
    HrirSet, wrap_degrees,
)
from aiogenomix.components.binaural.talkers_experiment import (  # noqa: E402
    TRAINING_ROOMS, Summary, TalkerCase, TalkersConfig, head_set, match_talkers, run_talkers, summarise_talkers,
    turning_head,
)

#: The seed of the training cases (the experiment's is 31).
SEED = 777
#: The heads the parameters are set on (never the experiment's snowman).
TRAINING_HEADS = ("kemar", "sphere")
#: The training turn, degrees (either way, alternately).
TURN = 30.0

#: The largest turns the experiment's planner (``filter``) may be allowed, degrees.
LARGEST_TURNS = (30.0, 45.0, 60.0, 90.0)
#: How long the experiment's ``filter`` strategy may listen before each planned turn, seconds.
LOOKS = (0.5, 0.25, 0.2, 0.125)

#: The candidates: (name, glimpse parameters, counting rules, front/back weight of a turning head's filter).
CANDIDATES: list[tuple[str, GlimpseParameters, SourceCounting, float]] = [
    ("defaults", GlimpseParameters(), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("front/back weight 1 (all)", GlimpseParameters(), SourceCounting(), 1.0),
    ("front/back weight 0.3", GlimpseParameters(), SourceCounting(), 0.3),
    ("front/back weight 0.05", GlimpseParameters(), SourceCounting(), 0.05),
    ("front/back weight 0 (lateral only)", GlimpseParameters(), SourceCounting(), 0.0),
    ("noise margin 0", GlimpseParameters(noise_margin=0.0), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("sharpness 4", GlimpseParameters(sharpness=4.0), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("sharpness 16", GlimpseParameters(sharpness=16.0), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("no coherence weight", GlimpseParameters(coherence_power=0.0), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("coherence^8", GlimpseParameters(coherence_power=8.0), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("no onset bonus", GlimpseParameters(onset_gain=0.0), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("level^0.6", GlimpseParameters(level_power=0.6), SourceCounting(), TURNING_FRONT_BACK_WEIGHT),
    ("count from 3 %", GlimpseParameters(), SourceCounting(min_weight=0.03), TURNING_FRONT_BACK_WEIGHT),
    ("count from 8 %", GlimpseParameters(), SourceCounting(min_weight=0.08), TURNING_FRONT_BACK_WEIGHT),
    ("count any gain", GlimpseParameters(), SourceCounting(min_gain=0.0), TURNING_FRONT_BACK_WEIGHT),
    ("count from a gain of 0.3", GlimpseParameters(), SourceCounting(min_gain=0.3), TURNING_FRONT_BACK_WEIGHT),
]


def training_head(name: str) -> HrirSet:
    """The training head *name*: ``kemar`` (the templates' own) or ``sphere``."""
    return sphere_hrirs() if name == "sphere" else head_set(name)


def training_cases(config: TalkersConfig, count: int) -> list[dict[str, object]]:
    """The training scenes, per head: still and turning, rendered once and shared by every candidate."""
    rate = config.rate
    cases = []
    for head in TRAINING_HEADS:
        hrirs = training_head(head)
        for r_index, room in enumerate(TRAINING_ROOMS):
            for talkers in config.talkers:
                for index in range(count):
                    case = TalkerCase(config, room, hrirs, talkers, (SEED, r_index, talkers, index))
                    path = turning_head(0.0, TURN if index % 2 else -TURN, 0.5, config.turn_speed)
                    turning = case.render(1.0 + TURN / config.turn_speed, path)[:round(rate)]
                    cases.append({"head": head, "azimuths": case.azimuths, "still": case.render(1.0),
                                  "turning": turning, "path": path, "noise": case.noise(0.5)})
            print(f"rendered {head}, {room.name}", file=sys.stderr, flush=True)
    return cases


def score(config: TalkersConfig, cases: list[dict[str, object]], parameters: GlimpseParameters,
          counting: SourceCounting, front_back_weight: float) -> dict[tuple[str, str], tuple[float, float, float]]:
    """Per head and way of listening (still, turning): talkers within 5°, front/back confusions, counted right."""
    localiser = SourceLocaliser(dataclasses.replace(config.setup, rate=config.rate), parameters=parameters,
                                counting=counting)
    tallies: dict[tuple[str, str], dict[str, list[bool]]] = {}
    for case in cases:
        azimuths: npt.NDArray[np.float64] = np.asarray(case["azimuths"])
        localiser.learn_noise(np.asarray(case["noise"]))
        for which in ("still", "turning"):
            glimpses, centres = localiser.glimpses(np.asarray(case[which]))
            path = case["path"] if which == "turning" else (lambda _t: 0.0)
            heads = np.array([path(c / config.rate) for c in centres])  # type: ignore[operator]
            room = RoomAzimuthFilter(capacity=1000, counting=counting,
                                     front_back_weight=front_back_weight if which == "turning" else 1.0)
            room.add(glimpses, heads)
            found = [s.azimuth for s in room.sources(len(azimuths))]
            errors, columns = match_talkers(list(azimuths), found)
            tally = tallies.setdefault((str(case["head"]), which), {"within": [], "confused": [], "counted": []})
            tally["within"].extend(bool(e) for e in errors <= 5.0)
            tally["counted"].append(len(room.sources()) == len(azimuths))
            for talker, error, column in zip(azimuths, errors, columns, strict=True):
                mirror = float(wrap_degrees(180.0 - talker))
                if column is not None and abs(float(wrap_degrees(mirror - talker))) > 10.0:
                    tally["confused"].append(abs(float(wrap_degrees(found[column] - mirror))) < error)
    return {key: (float(np.mean(t["within"])), float(np.mean(t["confused"])), float(np.mean(t["counted"])))
            for key, t in tallies.items()}


def _filter_summaries(head: str, cases: int, **setting: Any) -> list[Summary]:
    """The ``filter`` strategy's measures on one training head with one of its settings changed."""
    config = dataclasses.replace(TalkersConfig(rooms=TRAINING_ROOMS, heads=(head,), cases=cases, seed=SEED,
                                               strategies=("filter",)), **setting)
    results, _ = run_talkers(config, heads=training_head)
    return summarise_talkers(results)


def sweep(setting: str, values: tuple[float, ...], label: str, cases: int, jobs: int) -> None:
    """The experiment's ``filter`` strategy in the training rooms, per head and value of one of its settings.

    Each head runs alone (its cases drawn as the experiment draws the first head's, from :data:`SEED`), so
    a head's figures do not depend on the other's; *jobs* processes share the runs.

    Args:
        setting: The :class:`TalkersConfig` field changed (``max_turn``, ``look``).
        values: Its values.
        label: How the table names it, with ``{}`` for a value.
        cases: Cases per head, room and number of talkers.
        jobs: Processes.
    """
    heads = TRAINING_HEADS
    with concurrent.futures.ProcessPoolExecutor(jobs) as pool:
        runs = {(value, head): pool.submit(_filter_summaries, head, cases, **{setting: value}) for value in values
                for head in heads}
        print(f"The planned turns, by {setting}: talkers within 5° / front-back confusions / counted right, %, "
              "both training rooms\n")
        print(f"| {setting} | " + " | ".join(f"{head}, {n} talker{'s' * (n > 1)}" for head in heads
                                            for n in (1, 2, 3)) + " | kemar, all | sphere, all |")
        print("|---|" + "---:|" * 8)
        for value in values:
            cells, overall = [], []
            for head in heads:
                summaries = runs[value, head].result()
                for n in (1, 2, 3):
                    chosen = [s for s in summaries if s.talkers == n]
                    cells.append(" / ".join(f"{100 * np.mean([getattr(s, field) for s in chosen]):.0f}"
                                            for field in ("within_5", "front_back", "count_right")))
                within = np.average([s.within_5 for s in summaries], weights=[s.talkers for s in summaries])
                overall.append(f"{100 * within:.0f}")
            print(f"| {label.format(value)} | " + " | ".join(cells + overall) + " |", flush=True)


def main() -> None:
    """Score every candidate on the training scenes; print a table."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int,
                        help="cases per head, room and number of talkers (6; --turns, --looks: 16)")
    parser.add_argument("--turns", action="store_true",
                        help="score the largest turn of the experiment's planner (its `filter` strategy) instead")
    parser.add_argument("--looks", action="store_true",
                        help="score how long each look of the experiment's planner (its `filter` strategy) lasts")
    parser.add_argument("--jobs", type=int, default=1, help="with --turns or --looks: processes sharing the runs")
    args = parser.parse_args()
    if args.turns:
        sweep("max_turn", LARGEST_TURNS, "{:.0f}°", args.cases or 16, args.jobs)
        return
    if args.looks:
        sweep("look", LOOKS, "{:g} s", args.cases or 16, args.jobs)
        return
    config = TalkersConfig()
    cases = training_cases(config, args.cases or 6)
    columns = [(head, which) for head in ("kemar", "sphere") for which in ("still", "turning")]
    print("Within 5° / front-back confusions / counted right, %\n")
    print("| candidate | " + " | ".join(f"{head}, {which}" for head, which in columns) + " |")
    print("|---|" + "---:|" * len(columns))
    for name, parameters, counting, front_back_weight in CANDIDATES:
        figures = score(config, cases, parameters, counting, front_back_weight)
        cells = [" / ".join(f"{100 * v:.0f}" for v in figures[column]) for column in columns]
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
