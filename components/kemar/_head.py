"""The KEMAR head on its Elmo drive: homing between the limit switches, position and velocity control."""

from __future__ import annotations

import asyncio
import contextlib
import enum
import logging
from collections.abc import Awaitable, Callable, Iterator
from dataclasses import dataclass

from ..core import Clock

from ._codec import INPUT_FORWARD_LIMIT, INPUT_REVERSE_LIMIT, NmtCommand, StatusRegister, describe_motor_fault
from ._driver import HarmonicaDriver
from ._errors import (
    DriveFault,
    DriveTimeout,
    HomingFailed,
    InvalidCommand,
    KemarError,
    MotionStopped,
    MotionTimeout,
    NotHomed,
)
from ._profile import move_duration

__all__ = ["KemarHead", "HeadConfig", "HeadState", "MotionType"]

_log = logging.getLogger(__name__)



@dataclass(frozen=True)
class HeadConfig:
    """The constants of the KEMAR rig (``kemar-control``'s axis parameters and GenoM codels).

    Attributes:
        encoder_lines: Encoder lines per motor turn.
        quadrature: Counts per encoder line.
        gear_ratio: Motor turns per head turn.
        acceleration: AC, counts/s².
        deceleration: DC, counts/s².
        max_speed: Highest speed accepted, counts/s.
        homing_speed: Jog speed while looking for the switches, counts/s.
        homing_timeout: Seconds allowed to reach each switch.
        homing_poll: Seconds between two reads of the inputs while homing.
        centring_tolerance: Counts within which the head must be centred.
        centring_timeout: Seconds allowed to centre the head.
        settle_delay: Seconds to wait at the centre before zeroing the encoder.
        target_radius: TR[1], counts: a move ends within this distance of its target.
        target_time_ms: TR[2], ms the head must stay within TR[1] to be settled.
        limit_margin: Position targets are clamped this many degrees inside the limits.
        velocity_margin: Velocity control stops the head this many degrees before a limit.
        default_speed: Position-control speed after homing, deg/s.
        poll_period: Seconds between two state reads while moving.
        reverse_input_logic: (input, IL value) of the reverse limit switch (RLS hard stop, active high).
        forward_input_logic: (input, IL value) of the forward limit switch (FLS hard stop, active high).
        min_range: Smallest distance between the switches homing accepts, degrees.
    """

    encoder_lines: int = 2048
    quadrature: int = 4
    gear_ratio: float = 9.0
    acceleration: int = 300_000
    deceleration: int = 300_000
    max_speed: int = 200_000
    homing_speed: int = 10_000
    homing_timeout: float = 10.0
    homing_poll: float = 0.25
    centring_tolerance: int = 4
    centring_timeout: float = 10.0
    settle_delay: float = 0.5
    target_radius: int = 15
    target_time_ms: int = 200
    limit_margin: float = 0.5
    velocity_margin: float = 3.0
    default_speed: float = 100.0
    poll_period: float = 0.01
    reverse_input_logic: tuple[int, int] = (5, 4 << 1 | 1)
    forward_input_logic: tuple[int, int] = (6, 5 << 1 | 1)
    min_range: float = 10.0

    @property
    def counts_per_degree(self) -> float:
        """Encoder counts per degree of head azimuth (204.8 on the rig)."""
        return self.encoder_lines * self.quadrature * self.gear_ratio / 360.0

    @property
    def max_speed_deg(self) -> float:
        """The highest speed in deg/s."""
        return self.max_speed / self.counts_per_degree


@dataclass(frozen=True)
class HeadState:
    """One reading of the head.

    Attributes:
        position: Azimuth in degrees (positive = left, towards the forward limit switch).
        speed: Angular speed in deg/s.
        max_left: Left limit found by homing, degrees (0 before homing).
        max_right: Right limit found by homing, degrees (0 before homing).
        timestamp: POSIX time of the reading (middle of the query round trip).
    """

    position: float
    speed: float
    max_left: float
    max_right: float
    timestamp: float


class MotionType(enum.IntEnum):
    """The drive's unit modes used for the head."""

    VELOCITY = 2
    POSITION = 5


StateListener = Callable[[HeadState], None]


class KemarHead:
    """The seed's Kemar library: the head on top of a :class:`HarmonicaDriver`.

    Every wait uses *clock*, so a sped-up clock speeds up homing and moves with
    the simulated drive.  Moves require a successful :meth:`home`; a cancelled
    move (an interrupted activity) stops the head before re-raising.

    Args:
        driver: A started driver.
        clock: The runtime clock.
        config: The rig's constants.
        on_state: Called with every state read (the component publishes it).
    """

    def __init__(
        self,
        driver: HarmonicaDriver,
        clock: Clock,
        config: HeadConfig | None = None,
        on_state: StateListener | None = None,
    ) -> None:
        self.driver = driver
        self.clock = clock
        self.config = config or HeadConfig()
        self.on_state = on_state
        self.homed = False
        self.max_left = 0.0
        self.max_right = 0.0
        self._speed = self.config.default_speed
        self._started = False
        self._saved_mi: int | None = None
        self._generation = 0

    async def aclose(self) -> None:
        """Close the driver and its bus (the host does, with the shared head)."""
        await self.driver.aclose()

    # ------------------------------------------------------------------ conversions and settings

    def to_counts(self, degrees: float) -> int:
        """Degrees of azimuth → encoder counts."""
        return round(degrees * self.config.counts_per_degree)

    def to_degrees(self, counts: float) -> float:
        """Encoder counts → degrees of azimuth."""
        return counts / self.config.counts_per_degree

    def clamp(self, target: float) -> float:
        """Clamp a target to half a degree (``limit_margin``) inside the homed limits."""
        margin = self.config.limit_margin
        return min(max(target, self.max_right + margin), self.max_left - margin)

    @property
    def speed(self) -> float:
        """The position-control speed in deg/s (100 after homing)."""
        return self._speed

    def set_speed(self, speed: float) -> None:
        """Set the position-control speed (deg/s) of the next moves.

        Raises:
            InvalidCommand: *speed* is not positive or exceeds the drive's maximum.
        """
        self._speed = self.check_speed(speed)

    def check_speed(self, speed: float) -> float:
        """Return *speed* if it is a usable position-control speed, else raise InvalidCommand."""
        if not 0 < speed <= self.config.max_speed_deg:
            raise InvalidCommand(f"speed must be in (0, {self.config.max_speed_deg:.1f}] deg/s, not {speed}")
        return speed

    # ------------------------------------------------------------------ reading

    async def start(self) -> None:
        """Put the drive in NMT operational and check it answers (done again after a time-out)."""
        with self._bus_guard():
            await self.driver.nmt(NmtCommand.START)
            await self.driver.status()
            self._started = True

    async def read_state(self) -> HeadState:
        """Read position and speed, publish the state to ``on_state`` and return it."""
        with self._bus_guard():
            await self._ensure_started()
            return await self._read_state()

    async def read_position(self) -> float:
        """Read the azimuth in degrees (one query: the fast path of ``GetPosition``)."""
        with self._bus_guard():
            await self._ensure_started()
            return self.to_degrees(await self.driver.query_int("PX"))

    async def _read_state(self) -> HeadState:
        before = self.clock.wall()
        position, velocity = await asyncio.gather(self.driver.query_int("PX"), self.driver.query_int("VX"))
        return self._publish(position, velocity, before)

    async def _poll(self) -> tuple[StatusRegister, HeadState]:
        before = self.clock.wall()
        status, position, velocity = await asyncio.gather(
            self.driver.status(), self.driver.query_int("PX"), self.driver.query_int("VX")
        )
        return status, self._publish(position, velocity, before)

    def _publish(self, position: int, velocity: int, before: float) -> HeadState:
        state = HeadState(
            self.to_degrees(position),
            self.to_degrees(velocity),
            self.max_left,
            self.max_right,
            (before + self.clock.wall()) / 2,
        )
        if self.on_state is not None:
            self.on_state(state)
        return state

    # ------------------------------------------------------------------ homing

    async def home(self) -> HeadState:
        """Find both limit switches, centre the head between them and zero the encoder there.

        The sequence of the rig: arm the switch inputs as hard stops, jog to the
        forward switch (homing-on-the-fly zeroes PX there), jog to the reverse
        switch, move to the midpoint, wait, and set PX=0.  A latched drive fault is
        cleared on the way (``MO=1``).

        Raises:
            HomingFailed: A switch was not reached in time or the range is implausible.
            DriveFault: The drive faulted during homing.
            DriveTimeout: The drive stopped answering.
        """
        config, drive = self.config, self.driver
        self.homed = False
        generation = self._next_generation()
        try:
            with self._bus_guard():
                await self._ensure_started()
                for index, value in (config.reverse_input_logic, config.forward_input_logic):
                    await drive.set("IL", value, index)
                if self._saved_mi is None:
                    self._saved_mi = await drive.query_int("MI")
                await drive.set("MI", 0xFFFF)
                await drive.set("HM", 0, 1)
                await self._switch_motion_type(MotionType.VELOCITY, recover=True)
                if await drive.query_int("IP") & INPUT_FORWARD_LIMIT:
                    await self._leave_forward_switch()
                # Forward switch: homing-on-the-fly loads PX := 0 when it triggers.
                for index, value in ((2, 0), (3, 5), (4, 0), (5, 0), (1, 1)):
                    await drive.set("HM", value, index)
                await self._jog(config.homing_speed)
                await self._wait_input(INPUT_FORWARD_LIMIT, "forward (left)")
                # Reverse switch: the event only stops the head, PX keeps counting.
                for index, value in ((1, 0), (3, 7), (5, 2), (1, 1)):
                    await drive.set("HM", value, index)
                await self._jog(-config.homing_speed)
                await self._wait_input(INPUT_REVERSE_LIMIT, "reverse (right)")
                await drive.set("HM", 0, 1)
                span = -await drive.query_int("PX")
                if span < config.min_range * config.counts_per_degree:
                    raise HomingFailed(
                        f"implausible range between the limit switches: {self.to_degrees(span):.1f} deg"
                    )
                centre = -round(span / 2)
                await self._switch_motion_type(MotionType.POSITION)
                await drive.set("SP", self.to_counts(config.default_speed))
                await drive.set("PA", centre)
                await drive.execute("BG")
                await self._wait_centred(centre)
                await self.clock.sleep(config.settle_delay)
                await drive.set("MO", 0)
                await drive.set("PX", 0)
                await drive.set("MO", 1)
                await drive.set("MI", self._saved_mi)
                self.max_left = self.to_degrees(span / 2)
                self.max_right = -self.max_left
                self._speed = config.default_speed
                self.homed = True
                return await self._read_state()
        except asyncio.CancelledError:
            await self._halt(generation)
            raise

    async def _leave_forward_switch(self) -> None:
        """Jog off the forward switch: its homing event fires on the rising edge only."""
        await self._jog(-self.config.homing_speed)
        deadline = self.clock.now() + self.config.homing_timeout
        while await self.driver.query_int("IP") & INPUT_FORWARD_LIMIT:
            if self.clock.now() > deadline:
                raise HomingFailed("the head did not leave the forward limit switch")
            await self.clock.sleep(self.config.poll_period)
        # Go about one degree further so that the switch is cleanly released.
        await self.clock.sleep(self.config.counts_per_degree / self.config.homing_speed)
        await self._stop_and_wait()

    async def _jog(self, counts_per_second: int) -> None:
        await self.driver.set("JV", counts_per_second)
        await self.driver.execute("BG")

    async def _wait_input(self, bit: int, name: str) -> None:
        deadline = self.clock.now() + self.config.homing_timeout
        while True:
            status, inputs = await asyncio.gather(self.driver.status(), self.driver.query_int("IP"))
            await self._check_fault(status)
            if inputs & bit:
                return
            if self.clock.now() > deadline:
                await self.driver.execute("ST")
                raise HomingFailed(
                    f"the {name} limit switch was not reached within {self.config.homing_timeout:g} s"
                )
            await self.clock.sleep(self.config.homing_poll)

    async def _wait_centred(self, centre: int) -> None:
        deadline = self.clock.now() + self.config.centring_timeout
        while True:
            status, state = await self._poll()
            await self._check_fault(status)
            if abs(self.to_counts(state.position) - centre) <= self.config.centring_tolerance:
                return
            if self.clock.now() > deadline:
                raise HomingFailed(f"the head did not reach the centre within {self.config.centring_timeout:g} s")
            await self.clock.sleep(self.config.poll_period)

    # ------------------------------------------------------------------ position control

    async def move_absolute(self, target: float, speed: float | None = None) -> HeadState:
        """Move to *target* degrees (clamped inside the limits) and wait for arrival.

        Args:
            target: Azimuth in degrees.
            speed: Speed of this move in deg/s; ``None`` or 0 uses :attr:`speed`.

        Raises:
            NotHomed: :meth:`home` has not succeeded.
            InvalidCommand: *speed* is out of range.
            MotionStopped: The head stopped before the target.
            DriveFault: The drive faulted.
            DriveTimeout: The drive stopped answering.
        """
        async def absolute() -> float:
            return target

        return await self._move(absolute, speed)

    async def move_relative(self, offset: float, speed: float | None = None) -> HeadState:
        """Move by *offset* degrees from the present azimuth (the target is clamped too).

        Raises:
            Same as :meth:`move_absolute`.
        """
        async def from_here() -> float:
            return self.to_degrees(await self.driver.query_int("PX")) + offset

        return await self._move(from_here, speed)

    async def _move(self, target: Callable[[], Awaitable[float]], speed: float | None) -> HeadState:
        """Run one position move to ``target()`` (read on the bus if needed), halting if it is cancelled."""
        self._require_homed()
        speed = self._speed if not speed else self.check_speed(speed)
        generation = self._next_generation()
        try:
            with self._bus_guard():
                await self._ensure_started()
                return await self._move_to(self.clamp(await target()), speed)
        except asyncio.CancelledError:
            await self._halt(generation)
            raise

    async def _move_to(self, target: float, speed: float) -> HeadState:
        config, drive = self.config, self.driver
        await self._switch_motion_type(MotionType.POSITION)
        counts = self.to_counts(target)
        start = await drive.query_int("PX")
        await drive.set("SP", self.to_counts(speed))
        await drive.set("PA", counts)
        await drive.execute("BG")
        expected = move_duration(counts - start, self.to_counts(speed), config.acceleration, config.deceleration)
        deadline = self.clock.now() + 2 * expected + 1.0
        while True:
            # The deadline is held against when the drive was asked, not when its answer came:
            # a reply that waited behind a stall of this process says "moving" about a time
            # before the deadline, and must not end a move that went as it should.
            asked = self.clock.now()
            status, state = await self._poll()
            await self._check_fault(status)
            if not status.motor_on:
                raise DriveFault("the drive switched the motor off during the move")
            if status.motion_status != 2:
                if abs(self.to_counts(state.position) - counts) <= config.target_radius:
                    return state
                cause = "a limit switch" if status.stopped_by_limit else "the drive"
                raise MotionStopped(
                    f"the head was stopped by {cause} at {state.position:.2f} deg, before {target:.2f} deg"
                )
            if asked > deadline:
                await drive.execute("ST")
                raise MotionTimeout(f"the move to {target:.2f} deg did not end within {2 * expected + 1:.1f} s")
            await self.clock.sleep(config.poll_period)

    # ------------------------------------------------------------------ velocity control

    async def control_in_speed(self, velocity: float) -> HeadState:
        """Turn at *velocity* deg/s until 0 is asked or the head gets near a limit.

        The head stops ``velocity_margin`` degrees before the limit in the
        direction of motion; this coroutine returns when the head has stopped.
        ``velocity == 0`` just stops the head.  The position-control speed is
        left unchanged.

        The drive's own profiler runs the head at *velocity* towards that stopping
        point and brakes onto it, so a slow host or bus cannot make the head
        overshoot (a host watching the position in speed mode would brake late by
        its polling latency).

        Raises:
            NotHomed: :meth:`home` has not succeeded.
            InvalidCommand: |velocity| exceeds the drive's maximum.
            DriveFault, DriveTimeout, MotionStopped: as for moves.
        """
        self._require_homed()
        if abs(velocity) > self.config.max_speed_deg:
            raise InvalidCommand(f"|velocity| must be at most {self.config.max_speed_deg:.1f} deg/s, not {velocity}")
        generation = self._next_generation()
        try:
            with self._bus_guard():
                await self._ensure_started()
                if velocity == 0:
                    return await self._stop_and_wait()
                margin = self.config.velocity_margin
                stop_at = self.max_left - margin if velocity > 0 else self.max_right + margin
                state = await self._read_state()
                if (stop_at - state.position) * velocity <= 0:
                    return state  # already at (or past) the stopping point on that side
                return await self._move_to(stop_at, abs(velocity))
        except asyncio.CancelledError:
            await self._halt(generation)
            raise

    async def stop(self) -> HeadState:
        """Stop the head (deceleration SD) and wait until it stands still."""
        self._next_generation()
        with self._bus_guard():
            await self._ensure_started()
            return await self._stop_and_wait()

    async def _stop_and_wait(self) -> HeadState:
        await self.driver.execute("ST")
        return await self._wait_stopped()

    async def _wait_stopped(self) -> HeadState:
        deadline = self.clock.now() + 5.0
        while True:
            status, state = await self._poll()
            await self._check_fault(status)
            if state.speed == 0 and status.motion_status != 2:
                return state
            if self.clock.now() > deadline:
                raise MotionTimeout("the head did not stop within 5 s")
            await self.clock.sleep(self.config.poll_period)

    # ------------------------------------------------------------------ plumbing

    async def _switch_motion_type(self, motion_type: MotionType, *, recover: bool = False) -> None:
        """Put the drive in *motion_type* with the motor on (the motor must be off to change UM).

        Args:
            motion_type: Position or velocity.
            recover: Clear a latched fault (MO=1) instead of raising DriveFault.
        """
        config, drive = self.config, self.driver
        status = await drive.status()
        if not recover:
            await self._check_fault(status)
        if status.unit_mode == motion_type and status.motor_on and not recover:
            return
        if status.motor_on and status.motion_status == 2:
            await self._stop_and_wait()
        await drive.set("MO", 0)
        await drive.set("UM", int(motion_type))
        if motion_type is MotionType.POSITION:
            await drive.set("TR", config.target_radius, 1)
            await drive.set("TR", config.target_time_ms, 2)
        else:
            await drive.set("PM", 1)
            await drive.set("RM", 0)
        await drive.set("AC", config.acceleration)
        await drive.set("DC", config.deceleration)
        await drive.set("MO", 1)
        drive.clear_emergency()

    async def _check_fault(self, status: StatusRegister) -> None:
        """Raise DriveFault when the drive has latched a fault or sent an emergency."""
        emergency = self.driver.latched_emergency
        if not (status.motor_fault or status.drive_problem or emergency is not None):
            return
        motor_fault = await self.driver.query_int("MF")
        reasons = []
        if motor_fault:
            reasons.append(describe_motor_fault(motor_fault))
        if emergency is not None:
            reasons.append(emergency.description)
        if status.drive_problem:
            reasons.append(status.describe())
        raise DriveFault(
            f"drive fault: {'; '.join(reasons) or 'unknown'} (the motor is off; Homing clears it)", motor_fault
        )

    def _require_homed(self) -> None:
        if not self.homed:
            raise NotHomed("the head is not homed: call Homing first")

    async def _ensure_started(self) -> None:
        if not self._started:
            await self.driver.nmt(NmtCommand.START)
            self._started = True

    def _next_generation(self) -> int:
        self._generation += 1
        return self._generation

    async def _halt(self, generation: int) -> None:
        """The stop path of an interrupted command: stop the head unless a newer command owns it."""
        if generation != self._generation:
            return
        try:
            await self.driver.execute("ST")
        except KemarError as exc:
            # Already being cancelled: the interruption must go on, the failure is reported.
            _log.warning("could not stop the head after an interruption: %s", exc)

    @contextlib.contextmanager
    def _bus_guard(self) -> Iterator[None]:
        """After a time-out, send NMT start again next time (the drive may have rebooted)."""
        try:
            yield
        except DriveTimeout:
            self._started = False
            raise
