"""The ``kemar`` component: the KEMAR head over CAN, with the services of the seed's ``.gen``."""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Callable, Iterator
from typing import Annotated

from ..audio import HeadAzimuth
from ..binaural import TurnableHead
from ..core import Component, ComponentHost, Double, Out, OutPort, Task, activity, function, Unit
from ._driver import HarmonicaDriver
from ._errors import (
    BusError,
    CodecError,
    DriveCommandError,
    DriveFault,
    DriveTimeout,
    HomingFailed,
    InvalidCommand,
    KemarError,
    MotionStopped,
    MotionTimeout,
    NotHomed,
    SdoAbortError,
    SimulatedDriveError,
)
from ._head import HeadConfig, HeadState, KemarHead
from ._simdrive import SimulatedHarmonica
from ._types import (
    BUS_ERROR,
    BUS_TIMEOUT,
    DRIVE_ERROR,
    DRIVE_FAULT,
    HOMING_FAILED,
    INVALID_TARGET,
    INVALID_VELOCITY,
    MOTION_STOPPED,
    NOT_HOMED,
    KemarState,
    MoveOutcome,
    Timestamp,
)

__all__ = ["Kemar", "simulated_rig", "parse_bus", "SIMULATED_BUS", "TURN_LIMITS"]

log = logging.getLogger(__name__)

#: The ``can`` setting of a simulated drive in-process, on a python-can virtual bus.
SIMULATED_BUS = "virtual"

#: The services that move the head; each interrupts the others.
MOTIONS = ("Homing", "MoveAbsolutePosition", "MoveRelativePosition", "ControlInSpeed")

_BUS_THROWS = (DRIVE_FAULT, BUS_TIMEOUT, BUS_ERROR, DRIVE_ERROR)

#: The azimuths active listening may turn the head to: the rig's limit switches at ±90°, less the
#: 0.5° that moves keep inside them (the drive clamps targets to the limits homing found).
TURN_LIMITS = (-89.5, 89.5)


def parse_bus(setting: str) -> tuple[str, str | None]:
    """Split the ``can`` setting into a python-can (interface, channel).

    ``"virtual"`` gives ``("virtual", None)``: the simulated drive in-process.
    ``"socketcan:can0"`` gives ``("socketcan", "can0")``.

    Raises:
        BusError: The setting has no ``interface:channel`` form.
    """
    if setting == SIMULATED_BUS:
        return "virtual", None
    interface, sep, channel = setting.partition(":")
    if not sep or not interface or not channel:
        raise BusError(f"bad CAN bus {setting!r}: use 'virtual' or INTERFACE:CHANNEL such as socketcan:can0")
    return interface, channel


def simulated_rig(host: ComponentHost) -> SimulatedHarmonica | None:
    """The host's simulated KEMAR drive (started on first use), or None on a real bus.

    One per host, shared by every component that drives the head (``kemar``,
    ``kemarcapture``): one simulated head, as on the rig.
    """
    if host.settings.can != SIMULATED_BUS:
        return None
    return host.shared(SimulatedHarmonica, lambda: SimulatedHarmonica(clock=host.clock).start())


class HeadListeners:
    """Who shows the host's one head: every component that drives it publishes each state any of them reads.

    ``kemar`` and ``kemarcapture`` loaded together turn one head (the simulated drive is
    shared, a real one is one device): a move made through one updates the other's
    ``currentState`` too, with the same reading and time, so no port shows an old azimuth as new.
    """

    def __init__(self) -> None:
        self._listeners: list[Callable[[HeadState], None]] = []

    def add(self, listener: Callable[[HeadState], None]) -> None:
        """Call *listener* with every state read from the head, by any component."""
        self._listeners.append(listener)

    def discard(self, listener: Callable[[HeadState], None]) -> None:
        """Stop calling *listener* (nothing happens if it was not called)."""
        if listener in self._listeners:
            self._listeners.remove(listener)

    def publish(self, state: HeadState) -> None:
        """Hand *state* to every listener."""
        for listener in list(self._listeners):
            listener(state)


@contextlib.contextmanager
def _as_genom_exceptions() -> Iterator[None]:
    """Turn the head stack's errors into the component's declared exceptions."""
    try:
        yield
    except NotHomed as exc:
        raise NOT_HOMED(message=str(exc)) from exc
    except DriveFault as exc:
        raise DRIVE_FAULT(message=str(exc)) from exc
    except DriveTimeout as exc:
        raise BUS_TIMEOUT(message=str(exc)) from exc
    except DriveCommandError as exc:
        raise DRIVE_ERROR(message=str(exc), code=exc.code) from exc
    except HomingFailed as exc:
        raise HOMING_FAILED(message=str(exc)) from exc
    except (MotionStopped, MotionTimeout) as exc:
        raise MOTION_STOPPED(message=str(exc)) from exc
    except (BusError, SdoAbortError, CodecError, SimulatedDriveError) as exc:
        raise BUS_ERROR(message=str(exc)) from exc


class Kemar(Component, name="kemar", version="1.0"):
    """The motorised KEMAR head: an Elmo Harmonica drive on a CAN bus turns the head between two limit switches.

    Call Homing first: it finds both limit switches and makes the midpoint azimuth 0 (positive = left).
    The bus is the gateway's ``--can`` setting: ``virtual`` runs a simulated drive in-process.
    """

    motion = Task(period=0.01, doc="Drives the head; CurrentPosition publishes once per period")
    currentState = OutPort(KemarState, doc="Head azimuth (deg, positive = left), speed (deg/s), limits and time")

    config: HeadConfig = HeadConfig()

    async def on_start(self) -> None:
        self.currentState.publish(KemarState())
        self._listeners = self.host.shared(HeadListeners, HeadListeners)
        self._listeners.add(self._publish)
        rig = simulated_rig(self.host)
        if rig is not None:
            # The simulated sound scene turns with the simulated head, whoever captures it.
            self.provide(HeadAzimuth, HeadAzimuth(lambda: rig.head_azimuth))
            self.head()
        # Active listening (binauloc's FaceSource) turns the head through MoveAbsolutePosition.
        self.provide(TurnableHead, TurnableHead.by_service(self, self.azimuth_now, TURN_LIMITS))

    async def on_stop(self) -> None:
        # The head stays open with the host (another component may drive it): the host closes it.
        self._listeners.discard(self._publish)

    def head(self) -> KemarHead:
        """The host's one head, its bus opened on first use (by whichever component needs it first).

        Every component that drives the head shares it, as they share the drive: homing
        through one homes it for all, and every state read shows on each one's currentState.

        Raises:
            BUS_ERROR: The bus cannot be opened.
        """
        with _as_genom_exceptions():
            return self.host.shared(KemarHead, self._open_head)

    def _open_head(self) -> KemarHead:
        interface, channel = parse_bus(self.host.settings.can)
        if channel is None:
            rig = simulated_rig(self.host)
            assert rig is not None
            channel = rig.channel
        assert channel is not None  # the simulated rig always names its virtual channel
        driver = HarmonicaDriver.open(interface, channel, timeout=self.host.settings.can_timeout, clock=self.clock)
        driver.start()
        return KemarHead(driver, self.clock, self.config, on_state=self._listeners.publish)

    async def azimuth_now(self) -> float:
        """The head's azimuth read from the drive now (degrees), NaN when the drive does not answer."""
        try:
            return await self.head().read_position()
        except (KemarError, BUS_ERROR) as exc:
            log.warning("%s: head position unavailable (%s)", self.instance, exc)
            return math.nan

    def _publish(self, state: HeadState) -> None:
        self.currentState.publish(
            KemarState(state.position, state.speed, state.max_left, state.max_right,
                       Timestamp.from_seconds(state.timestamp))
        )

    # ------------------------------------------------------------------ validation

    def _check_velocity(self, velocity: float, *, signed: bool = False) -> None:
        maximum = self.config.max_speed_deg
        # NaN (a JSON null) compares false with everything: refuse it explicitly.
        if (not math.isfinite(velocity) or (abs(velocity) if signed else velocity) > maximum
                or (velocity < 0 and not signed)):
            raise INVALID_VELOCITY(velocity=velocity, maximum=maximum)

    def _check_homed(self) -> None:
        if not self.head().homed:
            raise NOT_HOMED(message="the head is not homed: call Homing first")

    def _validate_move(self, target: float, velocity: float) -> None:
        if not math.isfinite(target):
            raise INVALID_TARGET(target=target)
        self._check_velocity(velocity)
        self._check_homed()

    def _validate_speed_control(self, velocity: float) -> None:
        self._check_velocity(velocity, signed=True)
        self._check_homed()

    # ------------------------------------------------------------------ services

    @activity(motion=True, task=motion, interrupts=MOTIONS, throws=(HOMING_FAILED, *_BUS_THROWS),
              progress="currentState.position")
    async def Homing(self) -> None:
        """Find both limit switches, centre the head between them and make that azimuth 0 (speed: 100 deg/s)."""
        with _as_genom_exceptions():
            await self.head().home()

    @activity(task=motion, interrupts=("CurrentPosition",), throws=_BUS_THROWS)
    async def CurrentPosition(self) -> None:
        """Publish the head state on currentState once per motion period, until StopCurrentPosition."""
        head = self.head()
        with _as_genom_exceptions():
            while True:
                await head.read_state()
                await self.motion.tick()

    @function(interrupts=("CurrentPosition",))
    def StopCurrentPosition(self) -> None:
        """Stop publishing the head state (interrupts CurrentPosition)."""

    @function(throws=(INVALID_VELOCITY, BUS_ERROR))
    def SetVelocity(
            self, velocity: Annotated[Double, Unit("deg/s"), "Speed of position control in deg/s"] = 100.0) -> None:
        """Set the speed of the next position moves (Homing sets it back to 100 deg/s)."""
        self._check_velocity(velocity)
        head = self.head()
        try:
            head.set_speed(velocity)
        except InvalidCommand:
            raise INVALID_VELOCITY(velocity=velocity, maximum=self.config.max_speed_deg) from None

    @activity(motion=True, task=motion, interrupts=MOTIONS, validate=_validate_move,
              throws=(NOT_HOMED, INVALID_TARGET, INVALID_VELOCITY, MOTION_STOPPED, *_BUS_THROWS),
              progress="currentState.position")
    async def MoveAbsolutePosition(
        self,
        target: Annotated[Double, Unit("deg"),
                          "Azimuth in degrees (positive = left), kept 0.5 deg inside the limits"] = 0.0,
        velocity: Annotated[Double, Unit("deg/s"), "Speed in deg/s; 0 = the current speed (SetVelocity)"] = 0.0,
    ) -> MoveOutcome:
        """Turn the head to an azimuth and wait until it is there (or at the limit, when it is beyond)."""
        head = self.head()
        with _as_genom_exceptions():
            state = await head.move_absolute(target, velocity or None)
        return MoveOutcome(position=state.position, limited=head.clamp(target) != target)

    @activity(motion=True, task=motion, interrupts=MOTIONS, validate=_validate_move,
              throws=(NOT_HOMED, INVALID_TARGET, INVALID_VELOCITY, MOTION_STOPPED, *_BUS_THROWS),
              progress="currentState.position")
    async def MoveRelativePosition(
        self,
        target: Annotated[Double, Unit("deg"), "Degrees to turn from the present azimuth (positive = left)"] = 0.0,
        velocity: Annotated[Double, Unit("deg/s"), "Speed in deg/s; 0 = the current speed (SetVelocity)"] = 0.0,
    ) -> MoveOutcome:
        """Turn the head by an angle from where it is (the final azimuth is kept inside the limits)."""
        head = self.head()
        with _as_genom_exceptions():
            start = await head.read_position()
            state = await head.move_relative(target, velocity or None)
        return MoveOutcome(position=state.position, limited=head.clamp(start + target) != start + target)

    @activity(motion=True, task=motion, interrupts=MOTIONS,
              throws=(NOT_HOMED, INVALID_VELOCITY, MOTION_STOPPED, *_BUS_THROWS), validate=_validate_speed_control,
              progress="currentState.position")
    async def ControlInSpeed(
        self,
        velocity: Annotated[Double, Unit("deg/s"), "Angular speed in deg/s (positive = left); 0 stops the head"] = 0.0,
    ) -> None:
        """Turn the head at a constant speed until 0 is asked or it comes 3 degrees from a limit."""
        with _as_genom_exceptions():
            await self.head().control_in_speed(velocity)

    @function(throws=_BUS_THROWS)
    async def GetPosition(
            self) -> Annotated[Double, Unit("deg"), Out("position", "Head azimuth in degrees (positive = left)")]:
        """Read the head azimuth from the drive (before Homing, the zero is wherever the head was at power-up)."""
        with _as_genom_exceptions():
            return await self.head().read_position()
