"""The ``binauloc`` component: binaural localisation on the measured KEMAR, and head turns that tell front from back."""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
from collections.abc import AsyncIterator
from typing import Annotated, Any

import numpy as np

from ..bass import AudioPortData
from ..binaural import (
    TURNING_FRONT_BACK_WEIGHT, BinauralError, HeadTurnFailed, LocaliserSetup, NoiseLearner, RoomAzimuthFilter,
    SourceAzimuth, SourceLocaliser, SourcesEstimate, TurnableHead, TurnPlanner, radians, wrap_degrees,
)
from ..binaural import Window as WindowName
from ..core import (
    AudioStream, Component, Double, GenomServices, InPort, Out, OutPort, Task, ULong, activity, function,
    redeclare, Unit,
)
from ._feed import AudioBlock, NotStreaming, PortFeed
from ._history import EstimateHistory, EstimateWindow
from ._types import (
    MAX_SOURCES, AzimuthsData, EstimatesData, SourceAzimuthData, SourceData, Target, Window, e_head, e_noData,
    e_noHead, e_rate, e_setup,
)

__all__ = ["Binauloc"]

log = logging.getLogger(__name__)

#: The services that analyse the audio; each interrupts the others (one localiser, one stream).
ANALYSES = ("LearnNoise", "LocalizeSources", "FaceSource")
#: Bounds of Setup: an analysis a client may ask for holds at most this much memory and time per estimate.
MAX_FRAME = 16_384
MAX_SMOOTHING = 1_000
#: The window names of the localiser, by the IDL enum.
_WINDOWS: dict[Window, WindowName] = {Window.HANNING: "hanning", Window.HAMMING: "hamming", Window.BLACKMAN: "blackman",
            Window.RECTANGULAR: "rectangular"}


def _radians(degrees: float | None) -> float:
    """Degrees to radians in (-pi, pi]; None (unknown) to NaN, which travels as null."""
    return math.nan if degrees is None or not math.isfinite(degrees) else radians(degrees)


def _source_data(source: SourceAzimuth, head: float | None) -> SourceAzimuthData:
    """A source of an estimate (head frame, degrees) as the ports carry it."""
    return SourceAzimuthData(azimuth=radians(source.azimuth),
                             roomAzimuth=_radians(None if head is None else source.azimuth + head),
                             confidence=source.confidence, weight=source.weight, power=source.power)


class Binauloc(Component, name="binauloc", version="1.0"):
    """Binaural sound localisation on the measured KEMAR HRTFs, after the Two!Ears ``binauloc``.

    Connect ``Audio`` to an audio port with connect_port (``bass/Audio``, ``capture/Port``,
    ``kemarcapture/Port``, or any component's whose type carries audio), then ``Setup``,
    ``LearnNoise`` while the sources are silent, and ``LocalizeSources``: each estimate of the
    dominant source's direction is published on ``Azimuths`` (radians in the head frame, with its
    confidence, the frame it refers to and,
    when the audio carries the head's azimuth, the room azimuth). ``FaceSource`` turns the head
    (kemar, kemarcapture or morse_kemar, whichever provides it) to tell front from back, then
    faces the source. Method: the ears' spatial covariance, less the noise's, matched against
    the steering vectors of the MIT KEMAR HRIRs at 72 azimuths (docs/localisation.md).
    """

    localize = Task(doc="Reads the connected audio port and localises, as the audio arrives")

    Audio = InPort(AudioPortData, carrying=AudioStream, doc=(
        "Connect to an audio port (bass/Audio, capture/Port, kemarcapture/Port, any component's): read by index "
        "without loss, with the head azimuths it carries"))
    Azimuths = OutPort(AzimuthsData, doc="The newest estimate: its sources, the strongest first")
    Estimates = OutPort(EstimatesData, view=EstimateWindow,
                        doc="The last 1024 estimates, numbered: read with since=K for those after K")
    Source = OutPort(SourceData, doc="What FaceSource found: every frame heard combined in the room, after each look")

    async def on_start(self) -> None:
        """No analysis yet: the default setup, no noise learnt, empty ports."""
        self._setup = LocaliserSetup(rate=0.0)
        self._localiser: SourceLocaliser | None = None
        self._history = EstimateHistory()
        self.Azimuths.publish(AzimuthsData())
        self.Estimates.publish(self._history.window)
        self.Source.publish(SourceData())

    # -- which port, which analysis ----------------------------------------------------------

    @redeclare(GenomServices.connect_port, doc=(
        "Connect the in port local to the out port remote (component/port): Audio to any audio port, bass/Audio, "
        "capture/Port, kemarcapture/Port or another component's."))
    async def connect_port(self, **inputs: Any) -> None:
        await GenomServices.connect_port(self, **inputs)

    def _feed(self, head: TurnableHead | None) -> PortFeed:
        port = self.Audio
        if port.remote is None:
            raise e_noData(what="Audio is not connected: connect it to an audio port (bass/Audio, capture/Port, "
                                "kemarcapture/Port...)")
        # A port that carries the head's azimuth with each chunk (kemarcapture) needs no other head:
        # for the others, it is read as the audio arrives.
        kind = port.remote.type.carries if port.remote is not None else None
        carried = isinstance(kind, AudioStream) and kind.head_azimuth is not None
        position = None if carried or head is None else head.position
        return PortFeed(port, position, self.clock.wall)

    async def _localiser_for(self, rate: int) -> SourceLocaliser:
        """The localiser of the current setup at the port's *rate* (built on first use, off the event loop)."""
        if self._localiser is not None and self._localiser.setup.rate == rate:
            return self._localiser
        if self._setup.rate and self._setup.rate != rate:
            raise e_rate(setup=int(self._setup.rate), port=rate)
        if self._localiser is not None:
            log.warning("%s: the port's rate is now %d Hz: the noise learnt at %g Hz is forgotten",
                        self.instance, rate, self._localiser.setup.rate)
        setup = dataclasses.replace(self._setup, rate=float(rate))
        try:
            # The templates come from the HRIRs (read from the cache, or converted once per user).
            with self.clock.holding():
                self._localiser = await asyncio.to_thread(SourceLocaliser, setup)
        except BinauralError as exc:
            raise e_setup(what=str(exc)) from exc
        return self._localiser

    async def _blocks(self, feed: PortFeed) -> AsyncIterator[AudioBlock]:
        while True:
            try:
                yield await feed.next()
            except NotStreaming:
                raise e_noData(what=f"{feed.port.name} is no longer connected") from None

    async def _estimates(self, feed: PortFeed, count: int | None,
                         room: RoomAzimuthFilter | None = None) -> AsyncIterator[tuple[SourcesEstimate, int]]:
        """The estimates of the new audio, with the number of the last frame each rests on.

        Args:
            feed: The connected port's audio.
            count: Sources per estimate (None: counted).
            room: A filter every frame with a head azimuth feeds too.
        """
        origin: int | None = None
        async for block in self._blocks(feed):
            localiser = await self._localiser_for(block.rate)
            if origin is None or block.lost or block.restarted:
                if origin is not None:
                    why = "a new acquisition" if block.restarted else f"{block.lost} frames lost"
                    log.warning("%s: %s before frame %d: the estimates start again there", self.instance, why,
                                block.first)
                localiser.reset_stream()
                origin = block.first
            for estimate in localiser.feed(block.samples, block.heads, count, also=room):
                yield estimate, origin + estimate.end - 1

    def _publish(self, estimate: SourcesEstimate, frame: int, number: int) -> None:
        """Publish an estimate on Azimuths and in the history."""
        head = estimate.head_azimuth
        sources = tuple(_source_data(s, head) for s in estimate.sources[:MAX_SOURCES])
        window = self._history.append(frame, estimate.frames, _radians(head), sources)
        first = sources[0] if sources else SourceAzimuthData(azimuth=math.nan, roomAzimuth=math.nan)
        self.Azimuths.publish(AzimuthsData(
            azimuth=first.azimuth, confidence=first.confidence, frameIndex=frame, nFrames=estimate.frames,
            headAzimuth=_radians(head), roomAzimuth=first.roomAzimuth, estimate=number,
            logLikelihood=np.log(np.maximum(estimate.distribution, 1e-300)), nSources=len(sources),
            sources=list(sources), index=window.index))
        self.Estimates.publish(window)

    # -- services -----------------------------------------------------------------------------

    def _validate_setup(self, sampleRate: int, maxFrequency: float, frameSize: int, overlap: int, window: Window,
                        smoothing: int) -> None:
        if overlap >= frameSize:
            raise e_setup(what=f"the overlap ({overlap}) must be smaller than the frame ({frameSize})")
        if frameSize > MAX_FRAME or smoothing > MAX_SMOOTHING:
            raise e_setup(what=f"frames of at most {MAX_FRAME} samples and at most {MAX_SMOOTHING} frames an "
                               f"estimate (not {frameSize} and {smoothing})")
        try:
            dataclasses.replace(self._setup_of(sampleRate, maxFrequency, frameSize, overlap, window, smoothing),
                                rate=float(sampleRate or 44_100)).check()
        except BinauralError as exc:
            raise e_setup(what=str(exc)) from exc

    @staticmethod
    def _setup_of(sampleRate: int, maxFrequency: float, frameSize: int, overlap: int, window: Window,
                  smoothing: int) -> LocaliserSetup:
        return LocaliserSetup(rate=float(sampleRate), max_frequency=maxFrequency, frame=frameSize,
                              hop=frameSize - overlap, smoothing=smoothing, window=_WINDOWS[window])

    @function(interrupts=ANALYSES, throws=(e_setup,), validate=_validate_setup)
    def Setup(
        self,
        sampleRate: Annotated[ULong, Unit("Hz"), "Sample rate in Hz of the connected port (0: whatever it is)"] = 0,
        maxFrequency: Annotated[Double, Unit("Hz"), "Highest frequency analysed, Hz"] = 5000.0,
        frameSize: Annotated[ULong, "Samples per analysis frame (a power of two)"] = 1024,
        overlap: Annotated[ULong, "Samples each frame shares with the next (frames start frameSize - overlap "
                                  "apart)"] = 512,
        window: Annotated[Window, "Analysis window of each frame"] = Window.HANNING,
        smoothing: Annotated[ULong, "Frames per estimate"] = 10,
    ) -> None:
        """Set the analysis parameters (the Two!Ears scripts: 24414, 5000, 1024, 512, HANNING, 10).

        A new setup forgets the noise learnt: LearnNoise again.
        """
        self._setup = self._setup_of(sampleRate, maxFrequency, frameSize, overlap, window, smoothing)
        self._localiser = None

    def _validate_seconds(self, seconds: float) -> None:
        if not (math.isfinite(seconds) and 0 < seconds <= 60):
            raise e_setup(what=f"LearnNoise takes 0 to 60 seconds of noise, not {seconds!r}")

    @activity(task=localize, interrupts=ANALYSES, throws=(e_setup, e_noData, e_rate), validate=_validate_seconds)
    async def LearnNoise(
        self, seconds: Annotated[Double, Unit("s"), "Seconds of noise (the sources silent) to learn from"] = 2.0,
    ) -> Annotated[ULong, Out("nFrames", "Analysis frames learnt from")]:
        """Learn the noise's spatial covariance from the next seconds of audio, the sources silent.

        The localiser subtracts it from each estimate's covariance. It waits for the audio
        (an acquisition started after it is fine).
        """
        # Learnt as the audio arrives: what is held is the covariance's sums, never the seconds of audio.
        learner: NoiseLearner | None = None
        heard = wanted = 0
        async for block in self._blocks(self._feed(None)):
            localiser = await self._localiser_for(block.rate)
            if learner is None or learner.localiser is not localiser:
                learner, heard, wanted = localiser.noise_learner(), 0, round(seconds * block.rate)
            elif block.lost or block.restarted:
                learner.gap()  # no frame spans frames the port no longer held
            try:
                learner.feed(block.samples[:wanted - heard])
            except BinauralError as exc:
                raise e_setup(what=str(exc)) from exc
            heard += min(len(block.samples), wanted - heard)
            if heard >= wanted:
                break
        assert learner is not None
        try:
            learner.learnt()
        except BinauralError as exc:
            raise e_setup(what=str(exc)) from exc
        return learner.frames

    def _validate_localize(self, nEstimates: int, nSources: int) -> None:
        if nSources > MAX_SOURCES:
            raise e_setup(what=f"an estimate names at most {MAX_SOURCES} sources, not {nSources}")

    @activity(task=localize, interrupts=ANALYSES, throws=(e_setup, e_noData, e_rate), validate=_validate_localize,
              progress="Azimuths.estimate")
    async def LocalizeSources(
        self, nEstimates: Annotated[ULong, "Estimates to make before ending (0: until Stop)"] = 0,
        nSources: Annotated[ULong, "Sources each estimate names (0: as many as are found, at most 6)"] = 0,
    ) -> Annotated[ULong, Out("nEstimates", "Estimates made")]:
        """Localise the sources in the new audio: an estimate every smoothing frames, on Azimuths and Estimates.

        Reads the connected port from now on, by index, so no frame is skipped or read twice; lost
        frames (a reader too slow for the port) start a new run of estimates after the gap. Each
        estimate joins the numbered history (the Estimates port), which a client reads with
        since= to have every one.
        """
        made = 0
        head = self.host.find(TurnableHead)
        async for estimate, frame in self._estimates(self._feed(head), nSources or None):
            made += 1
            self._publish(estimate, frame, made)
            if made == nEstimates:
                break
        return made

    def _validate_face(self, turn: float, velocity: float, look: float, confidence: float, maxTurns: int,
                       target: Target, azimuth: float) -> None:
        checks = (("turn", turn, 0 < turn <= 90), ("velocity", velocity, 0 < velocity <= 900),
                  ("look", look, 0 < look <= 10), ("confidence", confidence, 0 < confidence < 1),
                  ("maxTurns", maxTurns, 1 <= maxTurns <= 20), ("azimuth", azimuth, -360 <= azimuth <= 360))
        for name, value, good in checks:
            if not (math.isfinite(value) and good):
                raise e_setup(what=f"{name} {value!r} is out of range (turn 0-90 deg, velocity 0-900 deg/s, "
                                   "look 0-10 s, confidence 0-1, maxTurns 1-20, azimuth -360-360 deg)")
        if self.host.find(TurnableHead) is None:
            raise e_noHead(what="no component of this host turns a head: load kemar, kemarcapture or morse_kemar")

    # A motion: it turns the head, so a component host stops it when the gateway that asked is gone.
    @activity(motion=True, task=localize, interrupts=ANALYSES, throws=(e_setup, e_noData, e_rate, e_noHead, e_head),
              validate=_validate_face, progress="Azimuths.estimate")
    async def FaceSource(
        self,
        turn: Annotated[Double, Unit("deg"), "The largest turn from one look to the next, degrees"] = 30.0,
        velocity: Annotated[Double, Unit("deg/s"), "Head speed, deg/s"] = 60.0,
        look: Annotated[Double, Unit("s"), "Seconds of audio heard from each head azimuth"] = 0.5,
        confidence: Annotated[Double, "Posterior probability within 10 degrees that settles it"] = 0.9,
        maxTurns: Annotated[ULong, "Looks from other azimuths before settling whatever the confidence"] = 4,
        target: Annotated[Target, "Which source to face: the loudest, or the one nearest azimuth"] = Target.LOUDEST,
        azimuth: Annotated[Double, "With NEAREST: the room azimuth the source is sought near, degrees"] = 0.0,
    ) -> Annotated[SourceData, Out("source", "The source found, and where the head ended")]:
        """Find the sources by turning the head, then face the one asked for (as far as the head turns).

        Every frame heard, those heard while the head turns included, joins a mixture of sources
        in the room at the head's azimuth of its time; between looks the head turns where the next
        look is expected to tell apart most of what is still confused (a source and its mirror
        image), at most ``turn`` degrees. After at least one turn, once the source asked for has a
        posterior of ``confidence`` within 10 degrees (or after ``maxTurns``), the head turns to it.
        Each estimate is published on Azimuths and Estimates, the combination on Source.
        """
        head = self.host.require(TurnableHead)
        room = RoomAzimuthFilter(capacity=4096, front_back_weight=TURNING_FRONT_BACK_WEIGHT)
        heard = _Heard()
        looks: list[float] = []

        async def listen() -> None:
            async for estimate, frame in self._estimates(self._feed(head), None, room):
                setup = self._localiser.setup if self._localiser is not None else self._setup
                heard.add(estimate.frames * setup.hop / setup.rate)
                self._publish(estimate, frame, heard.count)

        def chosen() -> SourceAzimuth | None:
            sources = room.sources()
            if not sources:
                return None
            if target == Target.NEAREST:
                return min(sources, key=lambda s: abs(float(wrap_degrees(s.azimuth - azimuth))))
            return max(sources, key=lambda s: s.power)

        listener = asyncio.create_task(listen(), name=f"{self.instance} FaceSource listener")
        try:
            reached = await head.position()
            looks.append(reached)
            await heard.wait_for(look, listener)
            if room.frames == 0:
                raise e_noData(what="the head's azimuth was unknown for every estimate (the head does not answer)")
            assert self._localiser is not None
            planner = TurnPlanner(self._localiser.analyser, tuple(t for t in (10.0, 20.0, 30.0, 45.0, 60.0, 90.0)
                                                                  if t <= turn) or (turn,))
            while len(looks) - 1 < maxTurns:
                found = chosen()
                if len(looks) > 1 and found is not None and found.confidence >= confidence:
                    break
                weights, _ = room.distribution()
                reached = await self._turn(head, planner.next_head(weights, looks, reached, head.limits), velocity)
                looks.append(reached)
                await heard.wait_for(look, listener)
                self.Source.publish(self._found(room, chosen(), reached, len(looks) - 1, heard.count, faced=False))
        finally:
            # Settled: what was heard decides where to face (the head's last turn adds nothing to it).
            listener.cancel()
            await asyncio.gather(listener, return_exceptions=True)
        found = chosen()
        if found is None:
            raise e_noData(what="no source was heard")
        reached = await self._turn(head, found.azimuth, velocity)
        faced = abs(math.remainder(found.azimuth - reached, 360.0)) <= 2.0
        result = self._found(room, found, reached, len(looks) - 1, heard.count, faced=faced)
        self.Source.publish(result)
        return result

    @staticmethod
    async def _turn(head: TurnableHead, target: float, velocity: float) -> float:
        try:
            return await head.turn_to(head.clip(target), velocity)
        except HeadTurnFailed as exc:
            raise e_head(what=str(exc)) from exc

    @staticmethod
    def _found(room: RoomAzimuthFilter, found: SourceAzimuth | None, head: float, turns: int, estimates: int, *,
               faced: bool) -> SourceData:
        weights, _ = room.distribution()
        sources = [_source_data(dataclasses.replace(s, azimuth=float(wrap_degrees(s.azimuth - head))), head)
                   for s in room.sources()[:MAX_SOURCES]]
        return SourceData(roomAzimuth=_radians(None if found is None else found.azimuth),
                          confidence=0.0 if found is None else found.confidence, headAzimuth=_radians(head),
                          faced=faced, turns=turns, estimates=estimates,
                          logLikelihood=np.log(np.maximum(weights, 1e-300)), sources=sources)

    @function(interrupts=ANALYSES)
    def Stop(self) -> None:
        """Stop LearnNoise, LocalizeSources or FaceSource (a head turning stops where it is)."""


class _Heard:
    """The audio FaceSource's estimates rest on, and a way to wait for more."""

    def __init__(self) -> None:
        self.count = 0
        self.seconds = 0.0
        self._more = asyncio.Event()

    def add(self, seconds: float) -> None:
        """Count an estimate resting on *seconds* of new audio."""
        self.count += 1
        self.seconds += seconds
        self._more.set()

    async def wait_for(self, seconds: float, listener: asyncio.Task[None]) -> None:
        """Wait until the estimates made from now on rest on *seconds* of audio.

        Raises:
            The listener's exception, when it fails first (no audio, a rate the setup refuses).
        """
        until = self.seconds + seconds - 1e-9
        while self.seconds < until:
            self._more.clear()
            waiter = asyncio.ensure_future(self._more.wait())
            try:
                done, _ = await asyncio.wait({waiter, listener}, return_when=asyncio.FIRST_COMPLETED)
            finally:
                waiter.cancel()
            if listener in done:
                await listener
                raise e_noData(what="the audio stopped")
