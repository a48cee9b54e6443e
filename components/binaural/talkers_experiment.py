"""The experiment of issue 31: one to three talkers in rooms, on the templates' head and another, still or turning.

Each **case** draws, from its own seed:

* a room (anechoic, or a hall of RT60 0.3, 0.6 or 0.9 s whose direct-to-reverberant ratio at 1.5 m
  is 5.5, 4.6 and 3.9 dB: :data:`TEST_ROOMS`) and a listener near its middle, the head facing +x
  (room azimuth 0°);
* one, two or three talkers at room azimuths on the 5° grid round the full circle, at least
  15° apart, 1.3 to 1.7 m away at the ears' height (Ma et al.'s were 1.5 m away), each a
  speech-like voice (male, female or child) of its own rhythm, equally loud 1 m away;
* a diffuse noise field about 25 dB below the talkers and sensor noise at −70 dB re full scale;
  the localisers learn the noise from half a second of it alone.

The scene is rendered by :func:`~._offline.render_scene` (image sources to order 3 through the
head's HRIRs, then a diffuse tail with Eyring's decay) through the MIT KEMAR, whose measured
directions are the localiser's templates, or through the snowman head (:func:`~._snowman.snowman_hrirs`),
which the templates never saw. Then the **strategies**, each with the same amount of audio
(1 s) unless named otherwise:

* ``today``: the dominant-source localiser of before (:class:`~._localiser.BinauralLocaliser`),
  1 s from a still head, the N highest separated peaks of its likelihood (what a client could do);
* ``still``: :class:`~._source_localiser.SourceLocaliser`, 1 s from a still head;
* ``Ma et al.``: 0.5 s, a turn of 20° towards the most likely source (the audio during the turn
  unused), 0.5 s; the two looks' posteriors added in the room, mirror images dropped
  (:func:`~._head_movement.ma_combine`);
* ``filter``: the seed's layers (B) + (C): a look of 0.2 s, then a turn where
  :class:`~._head_movement.TurnPlanner` expects to tell most (at most 60°), planned again from
  where the head is after each 0.2 s (the look and the largest turn chosen on the training rooms
  and heads), every frame fed to the room filter with the head's azimuth of its time, the frames
  heard while the head turns included, until 1 s of audio in all;
* ``still, 2 s`` and ``filter, 2 s``: the same with twice the audio.

The head turns as the KEMAR's drive turns it: up to :attr:`TalkersConfig.turn_speed`, speeding up
and slowing down at the drive's acceleration (:data:`KEMAR_ACCELERATION`, about 1,465°/s²): a look
of 0.2 s is shorter than most turns, which go on through the next look. The number of talkers is given to each
strategy; ``still`` and ``filter`` also count them (``counted``). Measures, per room, head,
number of talkers and strategy: the share of talkers found within 5° (estimates matched to
talkers one to one, the nearest first) and within 10°, the front/back confusion rate (talkers matched to an
estimate nearer their mirror image across the starting head's interaural axis than to
themselves, among talkers more than 5° from that axis), and the share of cases counted right.

Seeds, rooms and the listener's places are apart from those that set the localiser's
parameters (:data:`TRAINING_ROOMS`, ``examples/localisation_training.py``).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
from scipy import optimize

from ._geometry import Pose
from ._glimpses import GlimpseParameters, Glimpses
from ._head_movement import TurnPlanner, ma_combine, ma_turn, posterior_sum
from ._hrir_set import HrirSet, wrap_degrees
from ._kemar import load_kemar
from ._localiser import BinauralLocaliser, LocaliserSetup
from ._mixture import TURNING_FRONT_BACK_WEIGHT, RoomAzimuthFilter, SourceCounting
from ._offline import Talker, render_scene
from ._room import Shoebox
from ._signals import speech_like
from ._snowman import snowman_hrirs
from ._source_localiser import SourceLocaliser

__all__ = ["RoomCondition", "TEST_ROOMS", "TRAINING_ROOMS", "TalkersConfig", "CaseResult", "Summary",
           "STRATEGIES", "run_talkers", "summarise_talkers", "head_set", "TalkerCase", "match_talkers", "turning_head",
           "turn_time", "KEMAR_ACCELERATION"]

#: The strategies, in the order of the tables.
STRATEGIES = ("today", "still", "Ma et al.", "filter", "still, 2 s", "filter, 2 s")
#: Strategies that also count the talkers.
COUNTING = ("still", "filter")
_VOICES = ("male", "female", "child")
_TALKER_LEVEL = -20.0
_DIFFUSE_LEVEL = -50.0
_SENSOR_NOISE = -70.0
_ONSET = 0.25


@dataclasses.dataclass(frozen=True)
class RoomCondition:
    """A room of the experiment.

    Attributes:
        name: As the tables name it.
        dimensions: Metres (None: anechoic, the free field).
        rt60: Eyring's reverberation time, seconds (None: anechoic).
    """

    name: str
    dimensions: tuple[float, float, float] | None = None
    rt60: float | None = None

    def shoebox(self) -> Shoebox | None:
        """The room (None for the free field)."""
        if self.dimensions is None or self.rt60 is None:
            return None
        return Shoebox.with_rt60(self.dimensions, self.rt60)


#: The KEMAR drive's acceleration and deceleration, degrees per second squared (its ``AC`` and ``DC``,
#: 300,000 counts/s² at 204.8 counts per degree of the head).
KEMAR_ACCELERATION = 300_000 / 204.8

#: The rooms of the experiment (test scenes only): halls whose direct-to-reverberant ratio 1.5 m from a talker,
#: 5.5, 4.6 and 3.9 dB, is near Ma, May & Brown's rooms' (5.3-8.8 dB).
TEST_ROOMS = (RoomCondition("anechoic"), RoomCondition("A (0.3 s)", (14.0, 11.0, 5.0), 0.3),
              RoomCondition("B (0.6 s)", (18.0, 13.0, 7.0), 0.6), RoomCondition("C (0.9 s)", (21.0, 15.0, 8.0), 0.9))
#: The rooms the localiser's parameters were set in (never in the experiment).
TRAINING_ROOMS = (RoomCondition("T1 (0.45 s)", (16.0, 12.0, 6.0), 0.45),
                  RoomCondition("T2 (0.75 s)", (20.0, 14.0, 7.5), 0.75))


def head_set(name: str) -> HrirSet:
    """The head *name*: ``kemar`` (the templates') or ``snowman`` (another)."""
    if name == "kemar":
        return load_kemar()
    if name == "snowman":
        return snowman_hrirs()
    raise ValueError(f"no head {name!r}: kemar or snowman")


@dataclasses.dataclass(frozen=True)
class TalkersConfig:
    """What to run.

    Attributes:
        rooms: The rooms.
        heads: The heads that hear (``kemar``, ``snowman``).
        talkers: The numbers of simultaneous talkers.
        cases: Cases per room, head and number of talkers.
        rate: Sample rate in Hz.
        turn_speed: Degrees per second the head turns at most.
        turn_acceleration: Degrees per second squared the head speeds up and slows down at.
        max_turn: The planner's largest turn, degrees.
        look: Seconds the ``filter`` strategies listen before each planned turn (the first look included).
        seed: Base seed of the cases.
        setup: The localisers' analysis (its rate is replaced by *rate*).
        parameters: How the glimpses are weighed.
        counting: How talkers are counted.
        front_back_weight: The share of the templates' front/back preference the room filter of a head that
            turns keeps (``filter``, ``filter, 2 s``; :func:`~._glimpses.tempered`).
        strategies: Which strategies to run.
    """

    rooms: tuple[RoomCondition, ...] = TEST_ROOMS
    heads: tuple[str, ...] = ("kemar", "snowman")
    talkers: tuple[int, ...] = (1, 2, 3)
    cases: int = 40
    rate: float = 24_414.0
    turn_speed: float = 90.0
    turn_acceleration: float = KEMAR_ACCELERATION
    max_turn: float = 60.0
    look: float = 0.2
    seed: int = 31
    setup: LocaliserSetup = LocaliserSetup()
    parameters: GlimpseParameters = GlimpseParameters()
    counting: SourceCounting = SourceCounting()
    front_back_weight: float = TURNING_FRONT_BACK_WEIGHT
    strategies: tuple[str, ...] = STRATEGIES


@dataclasses.dataclass(frozen=True)
class CaseResult:
    """One case: the talkers' room azimuths and each strategy's estimates (degrees, room frame)."""

    room: str
    head: str
    azimuths: tuple[float, ...]
    estimates: dict[str, tuple[float, ...]]
    counted: dict[str, int]
    turns: dict[str, tuple[float, ...]]


@dataclasses.dataclass(frozen=True)
class Summary:
    """The measures of one room, head, number of talkers and strategy (shares in [0, 1])."""

    room: str
    head: str
    talkers: int
    strategy: str
    cases: int
    within_5: float
    front_back: float
    count_right: float = float("nan")
    within_10: float = float("nan")


@dataclasses.dataclass
class Timing:
    """Seconds of audio localised by the new localiser and the processor seconds it took."""

    audio: float = 0.0
    localise: float = 0.0
    render: float = 0.0


class TalkerCase:
    """One drawn scene, rendered on demand for a head path.

    Args:
        config: The experiment's settings (the rate).
        room: The room.
        hrirs: The head that hears.
        count: Talkers.
        seed: The case's seed (a sequence of integers).
    """

    def __init__(self, config: TalkersConfig, room: RoomCondition, hrirs: HrirSet, count: int,
                 seed: Sequence[int]) -> None:
        rng = np.random.default_rng(list(seed))
        self.config, self.hrirs, self.room = config, hrirs, room.shoebox()
        self.azimuths = _draw_azimuths(rng, count)
        if room.dimensions is None:
            self.listener = Pose(0.0, 0.0, 1.5)
        else:
            length, width, _ = room.dimensions
            self.listener = Pose(length / 2 + rng.uniform(-0.4, 0.4), width / 2 + rng.uniform(-0.4, 0.4), 1.5)
        rate = config.rate
        self.talkers = [Talker(speech_like(3.0, rate, np.random.default_rng([*seed, k]), _VOICES[k % 3]),
                               self.listener.at(float(a), distance=float(rng.uniform(1.3, 1.7))),
                               level=_TALKER_LEVEL, onset=_ONSET)
                        for k, a in enumerate(self.azimuths)]
        self.seed = int(rng.integers(1 << 30))

    def render(self, seconds: float, head: Callable[[float], float] | float = 0.0) -> npt.NDArray[np.float64]:
        """*seconds* of the scene after the talkers' onset, the head's room azimuth *head* (seconds from there)."""
        path = head if callable(head) else (lambda _t, fixed=float(head): fixed)
        ears = render_scene(self.talkers, self.listener, rate=self.config.rate, seconds=_ONSET + seconds,
                            room=self.room, hrirs=self.hrirs, head=lambda t: path(max(0.0, t - _ONSET)),
                            diffuse_level=_DIFFUSE_LEVEL, sensor_noise=_SENSOR_NOISE, seed=self.seed)
        return ears[round(_ONSET * self.config.rate):]

    def noise(self, seconds: float) -> npt.NDArray[np.float64]:
        """The noise alone (the diffuse field and the sensors), another stretch of it."""
        # A silent talker: the renderer wants one source at least.
        silent = Talker(np.zeros(1), self.listener.at(0.0, distance=1.0))
        return render_scene([silent], self.listener, rate=self.config.rate, seconds=seconds, room=self.room,
                            hrirs=self.hrirs, diffuse_level=_DIFFUSE_LEVEL, sensor_noise=_SENSOR_NOISE,
                            seed=self.seed + 1)


def _draw_azimuths(rng: np.random.Generator, count: int) -> npt.NDArray[np.float64]:
    """*count* room azimuths on the 5° grid, at least 15° apart."""
    grid = np.arange(-180.0, 180.0, 5.0)
    while True:
        chosen = rng.choice(grid, count, replace=False)
        apart = np.abs(wrap_degrees(chosen[:, np.newaxis] - chosen[np.newaxis, :])) + 360.0 * np.eye(count)
        if apart.min() >= 15.0:
            return np.sort(chosen)


def _trapezoid(distance: float, speed: float, acceleration: float) -> tuple[float, float, float]:
    """A turn of *distance* degrees: seconds speeding up (and as many slowing down), top speed, seconds at it."""
    ramp = speed / acceleration
    if distance < speed * ramp:               # a triangle: half the way speeding up, half slowing down
        ramp = math.sqrt(distance / acceleration)
        speed = acceleration * ramp
    return ramp, speed, (distance / speed - ramp if speed > 0 else 0.0)


def turn_time(distance: float, speed: float, acceleration: float = math.inf) -> float:
    """Seconds a turn of *distance* degrees takes (see :func:`turning_head`)."""
    ramp, _, cruise = _trapezoid(abs(distance), speed, acceleration)
    return 2.0 * ramp + cruise


def turning_head(start: float, target: float, at: float, speed: float,
                 acceleration: float = math.inf) -> Callable[[float], float]:
    """The head's azimuth over time: still at *start* until *at* seconds, then turning to *target*.

    The turn is a trapezoid of speed, as the KEMAR's drive makes it: up to *speed* (degrees per second)
    at *acceleration* (degrees per second squared; infinite: at *speed* at once), and down again to stop
    at *target*; a short turn never reaches *speed*.
    """
    step = float(wrap_degrees(target - start))
    distance = abs(step)
    ramp, speed, cruise = _trapezoid(distance, speed, acceleration)

    def moved(elapsed: float) -> float:
        if elapsed <= 0.0:
            return 0.0
        if elapsed >= 2.0 * ramp + cruise:
            return distance
        if elapsed < ramp:
            return 0.5 * acceleration * elapsed**2
        if elapsed < ramp + cruise:
            return 0.5 * speed * ramp + speed * (elapsed - ramp)
        return distance - 0.5 * acceleration * (2.0 * ramp + cruise - elapsed) ** 2

    def azimuth(seconds: float) -> float:
        return start + math.copysign(moved(seconds - at), step)

    return azimuth


def _path(turns: Sequence[tuple[float, float]], start: float, speed: float,
          acceleration: float = math.inf) -> Callable[[float], float]:
    """The head's azimuth over time through turns ``(at seconds, target azimuth)``, one after the other.

    Each turn starts where the head is at its time: a turn not finished when the next begins is cut short
    there (the head does not jump).
    """
    pieces: list[tuple[float, Callable[[float], float]]] = []

    def azimuth(seconds: float) -> float:
        current = start
        for at, piece in pieces:
            if seconds < at:
                break
            current = piece(seconds)
        return current

    for at, target in turns:      # in time order: each starts where the ones before left the head
        pieces.append((at, turning_head(azimuth(at), target, at, speed, acceleration)))
    return azimuth


class _Strategies:
    """The localisers and the planner of one head set of templates (the KEMAR), shared by every case."""

    def __init__(self, config: TalkersConfig) -> None:
        setup = dataclasses.replace(config.setup, rate=config.rate)
        self.config = config
        self.today = BinauralLocaliser(setup)
        self.new = SourceLocaliser(setup, parameters=config.parameters, counting=config.counting)
        self.planner = TurnPlanner(self.new.analyser, tuple(t for t in (10.0, 20.0, 30.0, 45.0, 60.0, 90.0)
                                                            if t <= config.max_turn))
        self.timing = Timing()

    def glimpses(self, audio: npt.NDArray[np.float64], path: Callable[[float], float],
                 offset: float = 0.0) -> tuple[Glimpses, npt.NDArray[np.float64]]:
        """The glimpses of *audio* (starting *offset* seconds into the scene) and the head's azimuth at each frame."""
        started = time.process_time()
        glimpses, centres = self.new.glimpses(audio)
        self.timing.localise += time.process_time() - started
        self.timing.audio += len(audio) / self.config.rate
        heads = np.array([path(offset + c / self.config.rate) for c in centres])
        return glimpses, heads

    def run(self, case: TalkerCase, count: int) -> tuple[dict[str, tuple[float, ...]], dict[str, int],
                                                     dict[str, tuple[float, ...]]]:
        config, rate = self.config, self.config.rate
        half, second = round(0.5 * rate), round(rate)
        started = time.process_time()
        still = case.render(2.0)
        noise = case.noise(0.5)
        self.timing.render += time.process_time() - started
        self.today.learn_noise(noise)
        self.new.learn_noise(noise)
        estimates: dict[str, tuple[float, ...]] = {}
        counted: dict[str, int] = {}
        turns: dict[str, tuple[float, ...]] = {}
        strategies = config.strategies
        if "today" in strategies:
            peaks = self.today.localise(still[:second]).likelihood.peaks(count, 15.0)
            estimates["today"] = tuple(p for p, _ in peaks)
        for name, seconds in (("still", 1.0), ("still, 2 s", 2.0)):
            if name in strategies:
                room = RoomAzimuthFilter(capacity=1000, counting=config.counting)
                room.add(*self.glimpses(still[:round(seconds * rate)], lambda _t: 0.0))
                estimates[name] = tuple(s.azimuth for s in room.sources(count))
                if name in COUNTING:
                    counted[name] = len(room.sources())
        first, first_heads = self.glimpses(still[:half], lambda _t: 0.0)
        if "Ma et al." in strategies:
            look = RoomAzimuthFilter(capacity=1000, counting=config.counting)
            look.add(first, first_heads)
            target = ma_turn(look.sources(1), 0.0)
            moving = turning_head(0.0, target, 0.5, config.turn_speed, config.turn_acceleration)
            arrived = 0.5 + turn_time(target, config.turn_speed, config.turn_acceleration)
            ears = self._render(case, arrived + 0.5, moving)
            after, after_heads = self.glimpses(ears[round(arrived * rate):round(arrived * rate) + half], moving,
                                               arrived)
            found = ma_combine(posterior_sum(first, first_heads), 0.0, posterior_sum(after, after_heads), target,
                               count, config.counting)
            estimates["Ma et al."], turns["Ma et al."] = tuple(s.azimuth for s in found), (target,)
        # The filter's first look: Ma et al.'s half second when it lasts as long, else heard anew.
        looked = round(config.look * rate)
        first_look = (first, first_heads) if looked == half else None
        for name, seconds in (("filter", 1.0), ("filter, 2 s", 2.0)):
            if name in strategies:
                if first_look is None:
                    first_look = self.glimpses(still[:looked], lambda _t: 0.0)
                found_turns, room = self._filter(case, *first_look, seconds)
                estimates[name], turns[name] = tuple(s.azimuth for s in room.sources(count)), found_turns
                if name in COUNTING:
                    counted[name] = len(room.sources())
        return estimates, counted, turns

    def _render(self, case: TalkerCase, seconds: float, path: Callable[[float], float]) -> npt.NDArray[np.float64]:
        started = time.process_time()
        ears = case.render(seconds, path)
        self.timing.render += time.process_time() - started
        return ears

    def _filter(self, case: TalkerCase, first: Glimpses, first_heads: npt.NDArray[np.float64],
                seconds: float) -> tuple[tuple[float, ...], RoomAzimuthFilter]:
        """Layers (B) + (C): a look, a planned turn, and so on every look until *seconds* of audio in all."""
        config, rate = self.config, self.config.rate
        look = config.look
        room = RoomAzimuthFilter(capacity=1000, counting=config.counting, front_back_weight=config.front_back_weight)
        room.add(first, first_heads)
        looks: list[float] = [0.0]
        planned: list[tuple[float, float]] = []
        path = _path(planned, 0.0, config.turn_speed, config.turn_acceleration)
        heard = look
        overlap = config.setup.frame - config.setup.hop
        while heard < seconds - 1e-9:
            weights, _ = room.distribution()
            # From where the head is: a turn longer than a look's travel is not over when the next is planned.
            target = self.planner.next_head(weights, looks, path(heard), (-90.0, 90.0))
            planned.append((heard, target))
            path = _path(planned, 0.0, config.turn_speed, config.turn_acceleration)
            until = min(seconds, heard + look)
            ears = self._render(case, until, path)
            piece, heads = self.glimpses(ears[round(heard * rate) - overlap:round(until * rate)], path,
                                         heard - overlap / rate)
            room.add(piece, heads)
            looks.append(path(until))
            heard = until
        return tuple(t for _, t in planned), room


def run_talkers(config: TalkersConfig = TalkersConfig(), *, progress: Callable[[str], None] | None = None,
                heads: Callable[[str], HrirSet] = head_set) -> tuple[list[CaseResult], Timing]:
    """Run every case of *config*; return the results and the new localiser's timing.

    Args:
        config: What to run.
        progress: Told a line after each room, head and number of talkers.
        heads: The HRIRs of a head named in ``config.heads`` (the training script's knows a training head).
    """
    strategies = _Strategies(config)
    results = []
    for h_index, head in enumerate(config.heads):
        hrirs = heads(head)
        for r_index, room in enumerate(config.rooms):
            for count in config.talkers:
                for index in range(config.cases):
                    case = TalkerCase(config, room, hrirs, count, (config.seed, h_index, r_index, count, index))
                    estimates, counted, turns = strategies.run(case, count)
                    results.append(CaseResult(room.name, head, tuple(float(a) for a in case.azimuths), estimates,
                                              counted, turns))
                if progress is not None:
                    progress(f"{head}, {room.name}, {count} talker(s): {config.cases} cases")
    return results, strategies.timing


def match_talkers(truth: Sequence[float], found: Sequence[float]) -> tuple[npt.NDArray[np.float64], list[int | None]]:
    """Each talker's error to the estimate matched to it one to one (the nearest first), and which estimate."""
    if not found:
        return np.full(len(truth), 180.0), [None] * len(truth)
    distance = np.abs(wrap_degrees(np.asarray(truth)[:, np.newaxis] - np.asarray(found)[np.newaxis, :]))
    rows, columns = optimize.linear_sum_assignment(distance)
    errors = np.full(len(truth), 180.0)
    which: list[int | None] = [None] * len(truth)
    for row, column in zip(rows, columns, strict=True):
        errors[row], which[row] = distance[row, column], int(column)
    return errors, which


def summarise_talkers(results: Sequence[CaseResult]) -> list[Summary]:
    """The measures per room, head, number of talkers and strategy, in the order met."""
    keys = list(dict.fromkeys((r.room, r.head, len(r.azimuths)) for r in results))
    summaries = []
    for room, head, count in keys:
        chosen = [r for r in results if (r.room, r.head, len(r.azimuths)) == (room, head, count)]
        for strategy in [s for s in STRATEGIES if s in chosen[0].estimates]:
            within: list[bool] = []
            within_10: list[bool] = []
            confused = counted_fb = 0
            for result in chosen:
                found = result.estimates[strategy]
                errors, which = match_talkers(result.azimuths, found)
                within.extend(bool(e) for e in errors <= 5.0)
                within_10.extend(bool(e) for e in errors <= 10.0)
                for talker, error, column in zip(result.azimuths, errors, which, strict=True):
                    mirror = float(wrap_degrees(180.0 - talker))
                    if abs(float(wrap_degrees(mirror - talker))) <= 10.0 or column is None:
                        continue
                    counted_fb += 1
                    confused += abs(float(wrap_degrees(found[column] - mirror))) < error
            right = [r.counted[strategy] == len(r.azimuths) for r in chosen if strategy in r.counted]
            summaries.append(Summary(room, head, count, strategy, len(chosen), float(np.mean(within)),
                                     confused / counted_fb if counted_fb else 0.0,
                                     float(np.mean(right)) if right else float("nan"), float(np.mean(within_10))))
    return summaries
