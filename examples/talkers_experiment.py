"""The experiment of issue 31 (docs/localisation.md): several talkers in rooms, two heads, still and turning heads.

Run it with the project's virtualenv (one core; about an hour for the full run on a quiet machine)::

    .venv/bin/python examples/talkers_experiment.py                 # print the tables
    .venv/bin/python examples/talkers_experiment.py --write         # and update the docs and the plot
    .venv/bin/python examples/talkers_experiment.py --cases 4 --rooms 2 --heads snowman   # a quick look
    .venv/bin/python examples/talkers_experiment.py --heads kemar --save k.json    # one head per process,
    .venv/bin/python examples/talkers_experiment.py --heads snowman --save s.json  # side by side,
    .venv/bin/python examples/talkers_experiment.py --load k.json s.json --header "..." --write   # then together
    .venv/bin/python examples/talkers_experiment.py --talkers 1 --cases 100 --seed 4242 \
        --strategies today still --paired still today    # two strategies on the same cases, case by case

``--write`` replaces the results part of the experiment's section of ``docs/localisation.md`` and
draws ``docs/images/talkers.png``. The protocol is the docstring of
``aiogenomix.components.binaural.talkers_experiment``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import pathlib
import platform
import re
import sys
import time
from typing import Any

# One core, as the figures claim (numpy's FFT is single-threaded; its BLAS might not be).
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from aiogenomix.components.binaural.talkers_experiment import (  # noqa: E402
    STRATEGIES, TEST_ROOMS, CaseResult, Summary, TalkersConfig, match_talkers, run_talkers, summarise_talkers,
)

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "localisation.md"
PLOT = ROOT / "docs" / "images" / "talkers.png"
BEGIN, END = "<!-- talkers: written by examples/talkers_experiment.py --write -->", "<!-- end of talkers -->"


def tables(summaries: list[Summary]) -> str:
    """One table per head: rows room × talkers, columns the strategies (within 5° / front/back), counts."""
    out = []
    strategies = [s for s in STRATEGIES if any(x.strategy == s for x in summaries)]
    for head in dict.fromkeys(s.head for s in summaries):
        out.append(f"**{head}** ({'the templates’ head' if head == 'kemar' else 'a head the templates never saw'}):"
                   " talkers within 5° (within 10°) / front-back confusions, %; cases counted right, %\n")
        out.append("| room | talkers | cases | " + " | ".join(strategies) + " | counted: still | counted: filter |")
        out.append("|---|---:|---:|" + "---:|" * (len(strategies) + 2))
        rows = dict.fromkeys((s.room, s.talkers) for s in summaries if s.head == head)
        for room, talkers in rows:
            cells = {s.strategy: s for s in summaries if (s.head, s.room, s.talkers) == (head, room, talkers)}
            first = next(iter(cells.values()))
            line = [room, str(talkers), str(first.cases)]
            line += [f"{100 * cells[s].within_5:.0f} ({100 * cells[s].within_10:.0f}) / "
                     f"{100 * cells[s].front_back:.0f}" if s in cells else "" for s in strategies]
            line += [f"{100 * cells[s].count_right:.0f}" if s in cells and np.isfinite(cells[s].count_right)
                     else "" for s in ("still", "filter")]
            out.append("| " + " | ".join(line) + " |")
        out.append("")
    return "\n".join(out)


def paired(results: list[CaseResult], first: str, second: str) -> str:
    """Two strategies on the same cases: per room, head and number of talkers, in how many cases each found more.

    A case counts for the strategy that found more of its talkers within 5°; the sign test's two-sided
    p-value says how likely so lopsided a split is if neither strategy is better.
    """
    from scipy import stats

    out = [f"Paired, case by case: cases where `{first}` found more talkers within 5° than `{second}`, and fewer\n",
           "| head | room | talkers | cases | more | fewer | sign test p |", "|---|---|---:|---:|---:|---:|---:|"]
    groups: dict[tuple[str, str, int], list[tuple[int, int]]] = {}
    compared = [r for r in results if first in r.estimates and second in r.estimates]
    if not compared:
        raise SystemExit(f"no case has both {first!r} and {second!r}")
    for result in compared:
        found = [int(np.sum(match_talkers(result.azimuths, result.estimates[name])[0] <= 5.0))
                 for name in (first, second)]
        groups.setdefault((result.head, result.room, len(result.azimuths)), []).append((found[0], found[1]))
    for (head, room, talkers), pairs in groups.items():
        more = sum(a > b for a, b in pairs)
        fewer = sum(a < b for a, b in pairs)
        p = stats.binomtest(more, more + fewer).pvalue if more + fewer else 1.0
        out.append(f"| {head} | {room} | {talkers} | {len(pairs)} | {more} | {fewer} | {p:.2g} |")
    return "\n".join(out) + "\n"


#: Issue 31's goals, talkers within 5° with head movement and the still head's audio, by number of talkers.
WITHIN_5_GOALS = {1: 0.98, 2: 0.95, 3: 0.90}


def plot(summaries: list[Summary], path: pathlib.Path) -> None:
    """Share within 5° per strategy, per head and number of talkers, averaged over the reverberant rooms."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    heads = list(dict.fromkeys(s.head for s in summaries))
    strategies = [s for s in STRATEGIES if any(x.strategy == s for x in summaries)]
    figure, axes = plt.subplots(1, len(heads), figsize=(5.5 * len(heads), 3.8), squeeze=False, sharey=True)
    for column, head in enumerate(heads):
        ax = axes[0, column]
        counts = sorted({s.talkers for s in summaries})
        width = 0.8 / len(strategies)
        for k, strategy in enumerate(strategies):
            values = [np.mean([s.within_5 for s in summaries if s.head == head and s.talkers == n
                               and s.strategy == strategy and s.room != "anechoic"] or [np.nan]) for n in counts]
            ax.bar(np.arange(len(counts)) + (k - len(strategies) / 2 + 0.5) * width, 100 * np.asarray(values),
                   width, label=strategy)
        for index, n in enumerate(counts):
            if n in WITHIN_5_GOALS:   # the goal of a turning head with the still head's audio, over the bars
                ax.hlines(100 * WITHIN_5_GOALS[n], index - 0.42, index + 0.42, colors="black", linestyles="dashed",
                          linewidth=1.0, label="goal" if index == 0 else None)
        ax.set_xticks(range(len(counts)), [f"{n} talker{'s' if n > 1 else ''}" for n in counts])
        ax.set_title(f"{head}: reverberant rooms", fontsize=10)
        ax.set_ylim(0, 100)
        if column == 0:
            ax.set_ylabel("talkers within 5° (%)")
    # Below the panels: inside, it hides bars.
    handles, labels = axes[0, 0].get_legend_handles_labels()
    figure.legend(handles, labels, fontsize=8, loc="lower center", ncol=len(labels), frameon=False)
    figure.tight_layout(rect=(0.0, 0.07, 1.0, 1.0))
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90)


def main() -> None:
    """Run the experiment as the command line asks; print the tables (and write them with --write)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=TalkersConfig().cases, help="cases per condition")
    parser.add_argument("--rooms", type=int, nargs="*", help="rooms by number (0: anechoic, 1-3: A-C)")
    parser.add_argument("--heads", nargs="*", default=list(TalkersConfig().heads), help="kemar, snowman")
    parser.add_argument("--talkers", type=int, nargs="*", default=list(TalkersConfig().talkers))
    parser.add_argument("--seed", type=int, default=TalkersConfig().seed, help="the cases' seed (31: the docs')")
    parser.add_argument("--strategies", nargs="*", default=list(STRATEGIES), choices=STRATEGIES, metavar="NAME",
                        help=f"which strategies to run ({', '.join(STRATEGIES)})")
    parser.add_argument("--paired", nargs=2, metavar=("A", "B"),
                        help="also compare two of the strategies case by case (a sign test)")
    parser.add_argument("--write", action="store_true", help="update docs/localisation.md and the plot")
    parser.add_argument("--save", type=pathlib.Path, help="also keep every case's results in this JSON file")
    parser.add_argument("--load", type=pathlib.Path, nargs="+",
                        help="run nothing: the tables of results kept by --save (several runs, e.g. one per head)")
    parser.add_argument("--header", help="with --load: the line that says how the loaded runs were made")
    args = parser.parse_args()
    if args.paired and not set(args.paired) <= set(args.strategies):
        parser.error("--paired compares two of the strategies run")
    if args.load:
        kept = load(args.load)
        summaries = summarise_talkers(kept)
        header = args.header or "Results loaded from " + ", ".join(map(str, args.load))
        write(header + "\n\n" + tables(summaries), summaries, args.write)
        if args.paired:
            print(paired(kept, *args.paired))
        return
    rooms = TEST_ROOMS if not args.rooms else tuple(TEST_ROOMS[i] for i in args.rooms)
    config = dataclasses.replace(TalkersConfig(), cases=args.cases, rooms=rooms, heads=tuple(args.heads),
                                 talkers=tuple(args.talkers), seed=args.seed, strategies=tuple(args.strategies))
    started = time.monotonic()
    results, timing = run_talkers(config, progress=lambda line: print(line, file=sys.stderr, flush=True))
    summaries = summarise_talkers(results)
    took = time.monotonic() - started
    if args.save is not None:
        args.save.write_text(json.dumps([dataclasses.asdict(r) for r in results]))
    header = (f"Measured {time.strftime('%Y-%m-%d')} on {platform.machine()}, Python {platform.python_version()}, "
              f"one core; {config.cases} cases per room, head and number of talkers, seed {config.seed}, "
              f"{config.rate:g} Hz, head turning at up to {config.turn_speed:g}°/s ({config.turn_acceleration:.0f}°/s² "
              f"either way), at most {config.max_turn:g}° a turn, a turn planned after each {config.look:g} s; "
              f"the run took {took / 60:.0f} min "
              f"(the new localiser at {timing.audio / max(timing.localise, 1e-9):.0f}× real time, processor time).")
    write(header + "\n\n" + tables(summaries), summaries, args.write)
    if args.paired:
        print(paired(results, *args.paired))


def load(paths: list[pathlib.Path]) -> list[CaseResult]:
    """The cases' results kept by ``--save`` in *paths*, in order."""
    def case(kept: dict[str, Any]) -> CaseResult:
        return CaseResult(**{**kept, "azimuths": tuple(kept["azimuths"]),
                             "estimates": {k: tuple(v) for k, v in kept["estimates"].items()},
                             "turns": {k: tuple(v) for k, v in kept["turns"].items()}})

    return [case(kept) for path in paths for kept in json.loads(path.read_text())]


def write(text: str, summaries: list[Summary], to_docs: bool) -> None:
    """Print the results' text; with *to_docs*, put it in the docs' experiment section and draw the plot."""
    print(text)
    if to_docs:
        doc = DOC.read_text()
        block = f"{BEGIN}\n{text}{END}"
        if BEGIN in doc:
            doc = re.sub(re.escape(BEGIN) + ".*?" + re.escape(END), lambda _m: block, doc, flags=re.S)
        else:
            raise SystemExit(f"{DOC} has no {BEGIN!r} marker")
        DOC.write_text(doc)
        plot(summaries, PLOT)
        print(f"wrote {DOC} and {PLOT}", file=sys.stderr)


if __name__ == "__main__":
    main()
