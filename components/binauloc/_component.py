"""The ``binauloc`` component: binaural localisation on the measured KEMAR, and head turns that tell front from back."""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
from collections.abc import AsyncIterator
from typing import Annotated, Any

from ..bass import AudioPortData
from ..binaural import (
    AzimuthEstimate, BinauralError, BinauralLocaliser, FrontBackPolicy, HeadTurnFailed, LocaliserSetup, NoiseLearner,
    TurnableHead, radians,
)
from ..binaural import Window as WindowName
from ..capture import PortData
from ..core import (
    AudioStream, Component, Double, InPortRuntime, InPort, Out, OutPort, Task, ULong, activity, function, redeclare,
    Unit,
)
from ..kemarcapture import KemarPortData
from ._feed import AudioBlock, NotStreaming, PortFeed
from ._types import AzimuthsData, SourceData, Window, e_head, e_noData, e_noHead, e_rate, e_setup

__all__ = ["Binauloc", "AUDIO_PORTS"]

log = logging.getLogger(__name__)

#: The audio in ports, each reading one kind of port (what its port numbers, frames or chunks, its type says).
AUDIO_PORTS = ("Audio", "CapturePort", "KemarPort")
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


class Binauloc(Component, name="binauloc", version="1.0"):
    """Binaural sound localisation on the measured KEMAR HRTFs, after the Two!Ears ``binauloc``.

    Connect ``Audio`` to ``bass/Audio`` (or ``CapturePort`` to ``capture/Port``, ``KemarPort`` to
    ``kemarcapture/Port``) with connect_port, then ``Setup``, ``LearnNoise`` while the sources are
    silent, and ``LocalizeSources``: each estimate of the dominant source's direction is published
    on ``Azimuths`` (radians in the head frame, with its confidence, the frame it refers to and,
    when the audio carries the head's azimuth, the room azimuth). ``FaceSource`` turns the head
    (kemar, kemarcapture or morse_kemar, whichever provides it) to tell front from back, then
    faces the source. Method: the ears' spatial covariance, less the noise's, matched against
    the steering vectors of the MIT KEMAR HRIRs at 72 azimuths (docs/localisation.md).
    """

    localize = Task(doc="Reads the connected audio port and localises, as the audio arrives")

    Audio = InPort(AudioPortData, doc="Connect to bass/Audio: frames, read by frame index without loss")
    CapturePort = InPort(PortData, doc="Connect to capture/Port: chunks, read by chunk index")
    KemarPort = InPort(KemarPortData, doc="Connect to kemarcapture/Port: chunks and the head azimuth of each")
    Azimuths = OutPort(AzimuthsData, doc="The newest estimate of the dominant source's direction")
    Source = OutPort(SourceData, doc="What FaceSource found: its estimates combined in the room, after each look")

    async def on_start(self) -> None:
        """No analysis yet: the default setup, no noise learnt, empty ports."""
        self._setup = LocaliserSetup(rate=0.0)
        self._localiser: BinauralLocaliser | None = None
        self._audio_in: str | None = None
        self.Azimuths.publish(AzimuthsData())
        self.Source.publish(SourceData())

    # -- which port, which analysis ----------------------------------------------------------

    @redeclare(Component.connect_port, doc=(
        "Connect the in port local to the out port remote (component/port): Audio to bass/Audio, CapturePort to "
        "capture/Port, KemarPort to kemarcapture/Port. The audio port connected last is the one analysed."))
    async def connect_port(self, **inputs: Any) -> None:
        await Component.connect_port(self, **inputs)
        if inputs["local"] in AUDIO_PORTS:
            self._audio_in = inputs["local"]

    def _feed(self, head: TurnableHead | None) -> PortFeed:
        name = self._audio_in or next((n for n in AUDIO_PORTS if getattr(self.port(n), "remote", None) is not None),
                                      None)
        if name is None:
            raise e_noData(what="no audio in port is connected: connect Audio to bass/Audio, CapturePort to "
                                "capture/Port or KemarPort to kemarcapture/Port")
        port = self.port(name)
        assert isinstance(port, InPortRuntime)
        # A port that carries the head's azimuth with each chunk (kemarcapture) needs no other head:
        # for the others, it is read as the audio arrives.
        kind = port.remote.type.carries if port.remote is not None else None
        carried = isinstance(kind, AudioStream) and kind.head_azimuth is not None
        position = None if carried or head is None else head.position
        return PortFeed(port, position, self.clock.wall)

    async def _localiser_for(self, rate: int) -> BinauralLocaliser:
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
                self._localiser = await asyncio.to_thread(BinauralLocaliser, setup)
        except BinauralError as exc:
            raise e_setup(what=str(exc)) from exc
        return self._localiser

    async def _blocks(self, feed: PortFeed) -> AsyncIterator[AudioBlock]:
        while True:
            try:
                yield await feed.next()
            except NotStreaming:
                raise e_noData(what=f"{feed.port.name} is no longer connected") from None

    async def _estimates(self, feed: PortFeed) -> AsyncIterator[tuple[AzimuthEstimate, int]]:
        """The estimates of the new audio, with the number of the last frame each rests on."""
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
            for estimate in localiser.feed(block.samples, block.heads):
                yield estimate, origin + estimate.end - 1

    def _publish(self, estimate: AzimuthEstimate, frame: int, number: int) -> None:
        head = estimate.head_azimuth
        self.Azimuths.publish(AzimuthsData(
            azimuth=estimate.azimuth, confidence=estimate.confidence, frameIndex=frame, nFrames=estimate.frames,
            headAzimuth=_radians(head), roomAzimuth=_radians(None if head is None else estimate.degrees + head),
            estimate=number, logLikelihood=estimate.likelihood.log_likelihood.copy()))

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

    @activity(task=localize, interrupts=ANALYSES, throws=(e_setup, e_noData, e_rate), progress="Azimuths.estimate")
    async def LocalizeSources(
        self, nEstimates: Annotated[ULong, "Estimates to make before ending (0: until Stop)"] = 0,
    ) -> Annotated[ULong, Out("nEstimates", "Estimates made")]:
        """Localise the dominant source in the new audio: an estimate every smoothing frames, on Azimuths.

        Reads the connected port from now on, by index, so no frame is skipped or read twice; lost
        frames (a reader too slow for the port) start a new run of estimates after the gap.
        """
        made = 0
        head = self.host.find(TurnableHead)
        async for estimate, frame in self._estimates(self._feed(head)):
            made += 1
            self._publish(estimate, frame, made)
            if made == nEstimates:
                break
        return made

    def _validate_face(self, turn: float, velocity: float, look: float, confidence: float, maxTurns: int) -> None:
        checks = (("turn", turn, 0 < turn <= 90), ("velocity", velocity, 0 < velocity <= 900),
                  ("look", look, 0 < look <= 10), ("confidence", confidence, 0 < confidence < 1),
                  ("maxTurns", maxTurns, 1 <= maxTurns <= 20))
        for name, value, good in checks:
            if not (math.isfinite(value) and good):
                raise e_setup(what=f"{name} {value!r} is out of range (turn 0-90 deg, velocity 0-900 deg/s, "
                                   "look 0-10 s, confidence 0-1, maxTurns 1-20)")
        if self.host.find(TurnableHead) is None:
            raise e_noHead(what="no component of this host turns a head: load kemar, kemarcapture or morse_kemar")

    # A motion: it turns the head, so a component host stops it when the gateway that asked is gone.
    @activity(motion=True, task=localize, interrupts=ANALYSES, throws=(e_setup, e_noData, e_rate, e_noHead, e_head),
              validate=_validate_face, progress="Azimuths.estimate")
    async def FaceSource(
        self,
        turn: Annotated[Double, Unit("deg"),
                         "Degrees each look turns the head from the start, the source's side first"] = 30.0,
        velocity: Annotated[Double, Unit("deg/s"), "Head speed, deg/s"] = 60.0,
        look: Annotated[Double, Unit("s"), "Seconds of audio heard from each head azimuth"] = 0.5,
        confidence: Annotated[Double, "Posterior probability within 10 degrees that settles it"] = 0.9,
        maxTurns: Annotated[ULong, "Looks from other azimuths before settling whatever the confidence"] = 4,
    ) -> Annotated[SourceData, Out("source", "The source found, and where the head ended")]:
        """Find the dominant source by turning the head, then face it (as far as the head turns).

        Listens from the head's azimuth, then from others (``turn`` degrees either side, the
        source's side first), while the estimates, each turned into the room with the head
        azimuths of its own frames (a turn during an estimate included), add up. Once the
        posterior within 10 degrees reaches ``confidence`` after at least one turn, the head
        turns to the source. Each estimate is published on Azimuths, the combination on Source.
        """
        head = self.host.require(TurnableHead)
        policy = FrontBackPolicy(turn=turn, limits=head.limits, confidence=confidence, max_turns=maxTurns)
        heard = _Heard()

        async def listen() -> None:
            async for estimate, frame in self._estimates(self._feed(head)):
                setup = self._localiser.setup if self._localiser is not None else self._setup
                heard.add(estimate.frames * setup.hop / setup.rate)
                self._publish(estimate, frame, heard.count)
                if estimate.head_azimuth is not None:
                    policy.add(estimate)

        listener = asyncio.create_task(listen(), name=f"{self.instance} FaceSource listener")
        try:
            start = await head.position()
            policy.looked(start)
            await heard.wait_for(look, listener)
            if policy.room is None:
                raise e_noData(what="the head's azimuth was unknown for every estimate (the head does not answer)")
            while (target := policy.next_look()) is not None:
                reached = await self._turn(head, target, velocity)
                policy.looked(reached)
                await heard.wait_for(look, listener)
                self.Source.publish(self._found(policy, reached, faced=False))
        finally:
            # Settled: what was heard decides where to face (the head's last turn adds nothing to it).
            listener.cancel()
            await asyncio.gather(listener, return_exceptions=True)
        azimuth, _ = policy.found()
        reached = await self._turn(head, policy.facing(), velocity)
        result = self._found(policy, reached, faced=abs(math.remainder(azimuth - reached, 360.0)) <= 2.0)
        self.Source.publish(result)
        return result

    @staticmethod
    async def _turn(head: TurnableHead, target: float, velocity: float) -> float:
        try:
            return await head.turn_to(head.clip(target), velocity)
        except HeadTurnFailed as exc:
            raise e_head(what=str(exc)) from exc

    @staticmethod
    def _found(policy: FrontBackPolicy, head: float, *, faced: bool) -> SourceData:
        azimuth, confidence = policy.found()
        room = policy.room
        assert room is not None
        return SourceData(roomAzimuth=_radians(azimuth), confidence=confidence, headAzimuth=_radians(head),
                          faced=faced, turns=max(0, len(policy.looks) - 1), estimates=policy.estimates,
                          logLikelihood=room.log_likelihood.copy())

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
