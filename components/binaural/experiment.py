"""The localisation experiment: sources all round a KEMAR in a diffuse field, localised with a still and a turning head.

For each signal, signal-to-noise ratio and source azimuth:

* the source (RMS −20 dB re full scale) is rendered through the interpolated
  HRIRs, the diffuse field apart at the signal-to-noise ratio asked (both
  measured at the ears, as mean power over the two), and sensor noise at −70 dB;
* the head starts at an azimuth drawn uniformly within ±10°, so that neither the
  head nor any source sits on a measured direction;
* the localiser learns the noise from a separate stretch of noise alone (another
  realisation, as ``binauloc``'s LearnNoise would), then takes one estimate per
  segment of ``segment`` seconds;
* **static**: three segments with the head still, combined;
  **rotation**: the head turns by +``turn`` and −``turn`` degrees between the
  segments (0.2 s per turn, audio during the turns unused), and the three
  estimates are combined in the room frame;
  **sweep**: the head turns all the time, from −``turn`` to +``turn`` degrees
  of its start at constant speed, while three segments' worth of audio goes by;
  the streaming localiser gets the head azimuth of every sample (as binauloc gets
  it from kemarcapture's positions), makes one estimate per segment, each made of
  runs of frames within which the head moved under a degree, and the three are
  combined in the room frame.

So the three cases rest on the same amount of audio; only the head's movement differs.

Measures: the median absolute azimuth error over the full circle, the median
error of the lateral angle (front and back folded onto each other), and the
front/back confusion rate: the share of estimates closer to the source's mirror
image across the interaural axis (of the head's starting position) than to the
source, among sources more than 5° from that axis.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from ._hrir_set import HrirSet, wrap_degrees
from ._kemar import load_kemar
from ._likelihood import AzimuthLikelihood, combine_in_room
from ._localiser import AzimuthEstimate, BinauralLocaliser, LocaliserSetup
from ._renderer import BinauralRenderer
from ._signals import SIGNALS

__all__ = ["ExperimentConfig", "CaseResult", "Summary", "run_experiment", "summarise", "folded", "offset_azimuths"]

_SOURCE_LEVEL = -20.0
_SENSOR_NOISE = -70.0
_TURN_SECONDS = 0.2


def offset_azimuths(count: int = 72) -> npt.NDArray[np.float64]:
    """*count* azimuths evenly round the circle, offset by half a step (72: 2.5°, 7.5°, …), in [-180, 180)."""
    step = 360.0 / count
    return np.asarray(wrap_degrees(np.arange(count) * step + step / 2.0))


def folded(azimuth: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The lateral angle: an azimuth (degrees) folded onto the front half, [-90, 90]."""
    a = wrap_degrees(azimuth)
    return np.asarray(np.where(np.abs(a) <= 90.0, a, np.sign(a) * 180.0 - a))


@dataclasses.dataclass(frozen=True)
class ExperimentConfig:
    """What to run.

    Attributes:
        azimuths: Source azimuths in the room, degrees.
        signals: Names from :data:`SIGNALS`.
        snrs: Signal-to-noise ratios against the diffuse field, dB.
        rate: Sample rate in Hz.
        segment: Seconds of audio per estimate.
        turn: Head turn in degrees either way (the rotation case).
        seed: Base seed of everything random.
        setup: The localiser's analysis parameters (its rate is replaced by *rate*).
    """

    azimuths: tuple[float, ...] = tuple(offset_azimuths(72))
    signals: tuple[str, ...] = ("noise", "speech-like", "tone complex")
    snrs: tuple[float, ...] = (20.0, 5.0)
    rate: float = 24_414.0
    segment: float = 0.5
    turn: float = 30.0
    seed: int = 2017
    setup: LocaliserSetup = LocaliserSetup()


@dataclasses.dataclass(frozen=True)
class CaseResult:
    """One source localised: azimuths in degrees, room frame."""

    signal: str
    snr: float
    azimuth: float
    head: float
    static: float
    rotation: float
    static_confidence: float
    rotation_confidence: float
    sweep: float = float("nan")
    sweep_confidence: float = 0.0


@dataclasses.dataclass(frozen=True)
class Summary:
    """The measures of one signal at one signal-to-noise ratio (errors in degrees, rates in [0, 1])."""

    signal: str
    snr: float
    cases: int
    static_lateral_median: float
    static_median: float
    static_front_back: float
    rotation_lateral_median: float
    rotation_median: float
    rotation_front_back: float
    sweep_lateral_median: float = float("nan")
    sweep_median: float = float("nan")
    sweep_front_back: float = float("nan")


@dataclasses.dataclass
class Timing:
    """Seconds of audio rendered and localised, and the processor seconds they took."""

    audio: float = 0.0
    render: float = 0.0
    localise: float = 0.0

    @property
    def render_factor(self) -> float:
        """Audio seconds rendered per processor second."""
        return self.audio / self.render if self.render else float("inf")

    @property
    def localise_factor(self) -> float:
        """Audio seconds localised per processor second."""
        return self.audio / self.localise if self.localise else float("inf")


def _render_segments(renderer: BinauralRenderer, dry: npt.NDArray[np.float64], heads: Sequence[float],
                     azimuth: float, rate: float, segment: int, timing: Timing) -> list[npt.NDArray[np.float64]]:
    """Render the segments at *heads*, with a turn between them; return the segments' audio."""
    pieces = []
    position = 0
    turn = round(_TURN_SECONDS * rate)
    started = time.process_time()
    for index, head in enumerate(heads):
        if index:
            renderer.render(dry[np.newaxis, position:position + turn], head, [azimuth])
            position += turn
        pieces.append(renderer.render(dry[np.newaxis, position:position + segment], head, [azimuth]))
        position += segment
    timing.render += time.process_time() - started
    return pieces


def run_experiment(config: ExperimentConfig = ExperimentConfig(), *, hrirs: HrirSet | None = None,
                   progress: Callable[[str], None] | None = None) -> tuple[list[CaseResult], Timing]:
    """Run every case of *config*.

    Args:
        config: What to run.
        hrirs: The measured set (default: MIT KEMAR).
        progress: Called with a line of text after each signal and ratio.

    Returns:
        One result per case, and the time rendering and localising took.
    """
    hrirs = hrirs if hrirs is not None else load_kemar()
    rate = config.rate
    setup = dataclasses.replace(config.setup, rate=rate)
    localiser = BinauralLocaliser(setup, hrirs=hrirs)
    segment = round(config.segment * rate)
    streaming = _streaming(localiser, segment, hrirs)
    turn = round(_TURN_SECONDS * rate)
    total = 3 * segment + 2 * turn
    timing = Timing()
    results = []
    for s_index, name in enumerate(config.signals):
        make = SIGNALS[name]
        for r_index, snr in enumerate(config.snrs):
            for a_index, azimuth in enumerate(config.azimuths):
                rng = np.random.default_rng([config.seed, s_index, r_index, a_index])
                head = float(rng.uniform(-10.0, 10.0))
                dry = make(total / rate, rate, rng) * 10.0 ** (_SOURCE_LEVEL / 20.0)
                results.append(_case(name, snr, float(azimuth), head, dry, hrirs, (localiser, streaming), config,
                                     segment, turn, rng, timing))
            if progress is not None:
                progress(f"{name} at {snr:g} dB: {len(config.azimuths)} azimuths")
    return results, timing


def _case(name: str, snr: float, azimuth: float, head: float, dry: npt.NDArray[np.float64], hrirs: HrirSet,
          localisers: tuple[BinauralLocaliser, BinauralLocaliser], config: ExperimentConfig, segment: int, turn: int,
          rng: np.random.Generator, timing: Timing) -> CaseResult:
    rate = config.rate
    localiser, streaming = localisers
    seed = int(rng.integers(2**31))
    static_heads = [head, head, head]
    turning_heads = [head, head + config.turn, head - config.turn]
    estimates = {}
    for label, heads in (("static", static_heads), ("rotation", turning_heads)):
        source = BinauralRenderer(rate, 1, hrirs=hrirs)
        target = _render_segments(source, dry, heads, azimuth, rate, segment, timing)
        started = time.process_time()
        field = BinauralRenderer(rate, 0, hrirs=hrirs, diffuse_level=0.0, sensor_noise=None, seed=seed)
        noise = field.render(np.zeros((0, 3 * segment + 2 * turn + segment)), head)
        timing.render += time.process_time() - started
        power = np.mean([np.mean(piece**2) for piece in target])
        gain = np.sqrt(power / 10.0 ** (snr / 10.0))
        sensor = 10.0 ** (_SENSOR_NOISE / 20.0)
        learn, noise = noise[:segment], noise[segment:]
        started = time.process_time()
        localiser.learn_noise(gain * learn + sensor * rng.standard_normal(learn.shape))
        observations = []
        for index, (piece, position) in enumerate(zip(target, heads, strict=True)):
            start = index * (segment + turn)
            mixed = piece + gain * noise[start:start + segment] + sensor * rng.standard_normal(piece.shape)
            observations.append((localiser.localise(mixed).likelihood, position))
        room = combine_in_room(observations)
        timing.localise += time.process_time() - started
        estimates[label] = (room.peak(), room.confidence())
    estimates["sweep"] = _sweep(dry[:3 * segment], azimuth, head, snr, hrirs, streaming, config, segment, seed, rng,
                                timing)
    timing.audio += 3 * 3 * segment / rate
    return CaseResult(name, snr, azimuth, head, estimates["static"][0], estimates["rotation"][0],
                      estimates["static"][1], estimates["rotation"][1], estimates["sweep"][0],
                      estimates["sweep"][1])


def _streaming(localiser: BinauralLocaliser, segment: int, hrirs: HrirSet) -> BinauralLocaliser:
    """The localiser of the sweep: the same analysis, one estimate per segment of audio."""
    per_estimate = (segment - localiser.setup.frame) // localiser.setup.hop + 1
    return BinauralLocaliser(dataclasses.replace(localiser.setup, smoothing=per_estimate), hrirs=hrirs)


def _sweep(dry: npt.NDArray[np.float64], azimuth: float, head: float, snr: float, hrirs: HrirSet,
           streaming: BinauralLocaliser, config: ExperimentConfig, segment: int, seed: int,
           rng: np.random.Generator, timing: Timing) -> tuple[float, float]:
    """The head turning all the time while three segments go by; estimates streamed with its azimuths."""
    rate = config.rate
    total = 3 * segment
    streaming.reset_stream()
    heads = head - config.turn + 2.0 * config.turn * np.arange(1, total + 1) / total
    # The renderer moves the head linearly within each block (filters cross-faded every sub-block of 741
    # samples), so blocks of 4096 samples make the same constant-speed turn as smaller ones.
    chunk = 4096
    started = time.process_time()
    source = BinauralRenderer(rate, 1, hrirs=hrirs)
    # No frame: the head where the turn starts, so that the first block turns from there as the azimuths
    # the localiser gets say (heads[k] is the azimuth at the end of sample k).
    source.render(dry[np.newaxis, :0], head - config.turn, [azimuth])
    ears = np.concatenate([source.render(dry[np.newaxis, at:at + chunk], float(heads[min(at + chunk, total) - 1]),
                                         [azimuth]) for at in range(0, total, chunk)])
    field = BinauralRenderer(rate, 0, hrirs=hrirs, diffuse_level=0.0, seed=seed + 1)
    noise = field.render(np.zeros((0, total + segment)), head)
    timing.render += time.process_time() - started
    gain = np.sqrt(np.mean(ears**2) / 10.0 ** (snr / 10.0))
    sensor = 10.0 ** (_SENSOR_NOISE / 20.0)
    learn, noise = noise[:segment], noise[segment:]
    mixed = ears + gain * noise + sensor * rng.standard_normal(ears.shape)
    started = time.process_time()
    streaming.learn_noise(gain * learn + sensor * rng.standard_normal(learn.shape))
    estimates: list[AzimuthEstimate] = []
    for at in range(0, total, chunk):
        estimates += streaming.feed(mixed[at:at + chunk], heads[at:at + chunk])
    rooms = [e.room for e in estimates if e.room is not None]
    room = AzimuthLikelihood(np.sum([r.log_likelihood for r in rooms], axis=0), "room")
    timing.localise += time.process_time() - started
    return room.peak(), room.confidence()


def _errors(results: Sequence[CaseResult], which: str) -> tuple[float, float, float]:
    true = np.array([r.azimuth for r in results])
    head = np.array([r.head for r in results])
    estimate = np.array([getattr(r, which) for r in results])
    full = np.abs(wrap_degrees(estimate - true))
    lateral = np.abs(folded(estimate - head) - folded(true - head))
    mirror = head + 180.0 - (true - head)
    counted = np.abs(wrap_degrees(mirror - true)) >= 10.0
    confused = np.abs(wrap_degrees(estimate - mirror)) < full
    rate = float(np.mean(confused[counted])) if counted.any() else 0.0
    return float(np.median(lateral)), float(np.median(full)), rate


def summarise(results: Sequence[CaseResult]) -> list[Summary]:
    """The measures per signal and signal-to-noise ratio, in the order met."""
    keys = list(dict.fromkeys((r.signal, r.snr) for r in results))
    summaries = []
    for signal_name, snr in keys:
        chosen = [r for r in results if (r.signal, r.snr) == (signal_name, snr)]
        static = _errors(chosen, "static")
        rotation = _errors(chosen, "rotation")
        sweep = _errors(chosen, "sweep")
        summaries.append(Summary(signal_name, snr, len(chosen), *static, *rotation, *sweep))
    return summaries
