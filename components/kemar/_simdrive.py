"""A simulated Elmo Harmonica drive turning the KEMAR head, on the far end of a python-can bus."""

from __future__ import annotations

import asyncio
import threading
import uuid
from dataclasses import dataclass
from types import TracebackType

import can

from ..core import Clock, RealClock

from ._codec import INPUT_FORWARD_LIMIT, INPUT_REVERSE_LIMIT, MotorFault
from ._drivemodel import HarmonicaModel
from ._errors import SimulatedDriveError

__all__ = ["SimulatedHarmonica", "DriveSnapshot", "COUNTS_PER_DEGREE", "DEFAULT_NODE_ID"]

#: The KEMAR drive's CANopen node id.
DEFAULT_NODE_ID = 0x7F
#: Encoder counts per degree of head azimuth: 2048 lines x 4 (quadrature) x 9 (gear) / 360.
COUNTS_PER_DEGREE = 2048 * 4 * 9 / 360


@dataclass(frozen=True)
class DriveSnapshot:
    """What the simulated drive is doing at one instant (for tests and the CLI).

    Attributes:
        time: Clock time of the snapshot.
        azimuth: True head azimuth in degrees (positive = left, towards the FLS).
        position: The encoder counter PX.
        velocity: Velocity in counts/s.
        motor_on: MO.
        unit_mode: UM.
        motor_fault: MF.
        forward_limit: FLS input active.
        reverse_limit: RLS input active.
    """

    time: float
    azimuth: float
    position: int
    velocity: float
    motor_on: bool
    unit_mode: int
    motor_fault: int
    forward_limit: bool
    reverse_limit: bool


class SimulatedHarmonica:
    """An Elmo Harmonica drive with the KEMAR head on its motor, served over a CAN bus.

    The drive runs on its own thread with its own python-can bus object, so it
    behaves like a separate device: it answers binary-interpreter requests on
    RPDO2/TPDO2, expedited SDOs and NMT, and sends EMCY frames.  Motion is
    trapezoidal and computed analytically from *clock*, so a sped-up clock speeds
    up the head.  The limit switches are hard stops at fixed head azimuths; the
    encoder frame is arbitrary until the host homes the head (PX is 0 at power-up
    wherever the head stands).

    Args:
        channel: Bus channel. For ``virtual``, ``None`` picks a unique channel name.
        interface: python-can interface name.
        bus: An already open bus to serve instead (not shut down by :meth:`close`).
        node_id: CANopen node id.
        clock: Time source (a ``ScaledClock`` runs the head faster).
        start_azimuth: Head azimuth at power-up, in degrees.
        limits: Azimuths of the (reverse, forward) limit switches, in degrees.
        counts_per_degree: Encoder counts per degree of azimuth.
        echo_sets: Answer set commands with their echo (as the drives in the field do).
        require_nmt_start: Ignore interpreter frames until an NMT start, like CANopen PDOs.
        stuck_timeout: Seconds of commanded motion without movement before a stuck
            motor latches a fault.
    """

    def __init__(
        self,
        channel: str | None = None,
        *,
        interface: str = "virtual",
        bus: can.BusABC | None = None,
        node_id: int = DEFAULT_NODE_ID,
        clock: Clock | None = None,
        start_azimuth: float = 0.0,
        limits: tuple[float, float] = (-90.0, 90.0),
        counts_per_degree: float = COUNTS_PER_DEGREE,
        echo_sets: bool = True,
        require_nmt_start: bool = True,
        stuck_timeout: float = 0.3,
    ) -> None:
        if not limits[0] < start_azimuth < limits[1]:
            raise ValueError(f"start azimuth {start_azimuth} must lie between the limits {limits}")
        if bus is not None:
            channel = str(bus.channel_info)
        elif channel is None:
            channel = f"kemar-sim-{uuid.uuid4().hex[:12]}"
        self.interface = interface
        self.channel: str = channel
        self.clock: Clock = clock or RealClock()
        self.counts_per_degree = counts_per_degree
        self._limits = limits
        self._model = HarmonicaModel(
            self.clock.now(),
            node_id=node_id,
            start_position=start_azimuth * counts_per_degree,
            reverse_switch=limits[0] * counts_per_degree,
            forward_switch=limits[1] * counts_per_degree,
            echo_sets=echo_sets,
            require_nmt_start=require_nmt_start,
            stuck_timeout=stuck_timeout,
        )
        self._own_bus = bus is None
        self._bus: can.BusABC = bus if bus is not None else can.Bus(interface=interface, channel=channel)
        # One lock for the model: the serving thread, the event loop (fault injection)
        # and the sound scene's thread (head_azimuth) all reach it.
        self._lock = threading.RLock()
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self._thread_error: BaseException | None = None
        self._closed = False
        self._silent = False
        #: Frames received and handled (for tests and the CLI).
        self.frames_received = 0

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> SimulatedHarmonica:
        """Start serving the bus on a background thread; returns ``self``."""
        if self._closed:
            raise SimulatedDriveError("the simulated drive is closed")
        if self._thread is None:
            with self._lock:
                self._model.boot()
            self._thread = threading.Thread(target=self._serve, name=f"sim-harmonica-{self.channel}", daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        """Stop the thread and release the bus (idempotent).

        Raises:
            SimulatedDriveError: The serving thread had died on an unexpected error.
        """
        if self._closed:
            return
        self._closed = True
        self._stopping.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        if self._own_bus:
            self._bus.shutdown()
        if self._thread_error is not None:
            raise SimulatedDriveError(f"simulated drive thread failed: {self._thread_error!r}") from self._thread_error

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._closed

    async def aclose(self) -> None:
        """Close from the event loop without blocking it."""
        await asyncio.to_thread(self.close)

    def __enter__(self) -> SimulatedHarmonica:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    async def __aenter__(self) -> SimulatedHarmonica:
        return self.start()

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.aclose()

    # ------------------------------------------------------------------ observation and fault injection

    @property
    def head_azimuth(self) -> float:
        """The true head azimuth in degrees, now (thread-safe; positive = left)."""
        with self._lock:
            now = self.clock.now()
            self._model.advance(now)
            return self._model.state_at(now)[0] / self.counts_per_degree

    def snapshot(self) -> DriveSnapshot:
        """Return the drive's state now (thread-safe)."""
        with self._lock:
            now = self.clock.now()
            model = self._model
            model.advance(now)
            position, velocity = model.state_at(now)
            inputs = model.inputs(position)
            return DriveSnapshot(
                now,
                position / self.counts_per_degree,
                model.encoder(position),
                velocity,
                model.motor_on,
                model.unit_mode,
                model.motor_fault,
                bool(inputs & INPUT_FORWARD_LIMIT),
                bool(inputs & INPUT_REVERSE_LIMIT),
            )

    @property
    def limit_azimuths(self) -> tuple[float, float]:
        """Azimuths (degrees) of the reverse and forward limit switches."""
        return self._limits

    def inject_fault(self, fault: int = MotorFault.POSITION_TRACKING, emergency_code: int = 0x8611) -> None:
        """Latch a motor fault: the motor switches off and an EMCY frame is sent.

        The fault stays latched (SR bit 6, MF) until the host sends ``MO=1``.

        Args:
            fault: MF bits to latch.
            emergency_code: The EMCY error code to send.
        """
        with self._lock:
            now = self.clock.now()
            self._model.advance(now)
            self._model.latch_fault(now, int(fault), emergency_code)
        self._flush()

    def set_silent(self, silent: bool) -> None:
        """Make the drive stop (or resume) answering anything on the bus."""
        with self._lock:
            self._silent = silent

    def set_stuck(self, stuck: bool) -> None:
        """Block (or free) the motor shaft: commanded motion then latches a stuck fault."""
        with self._lock:
            self._model.set_stuck(stuck, self.clock.now())

    def set_drag(self, share: float) -> None:
        """Make the motor reach only *share* of the commanded speed from the next motion command on.

        The drive reports the motion as running, faultless, until it arrives: a host learns of it
        only from its own deadline.  1 is nominal.

        Raises:
            ValueError: for a share outside (0, 1].
        """
        if not 0.0 < share <= 1.0:
            raise ValueError(f"the share of the commanded speed must be in (0, 1], not {share}")
        with self._lock:
            self._model.drag = share

    # ------------------------------------------------------------------ serving thread

    def _serve(self) -> None:
        try:
            self._flush()
            while not self._stopping.is_set():
                message = self._bus.recv(self._receive_timeout())
                with self._lock:
                    now = self.clock.now()
                    self._model.advance(now)
                    if message is not None and not self._ignored(message):
                        self.frames_received += 1
                        self._model.on_frame(message.arbitration_id, bytes(message.data), now)
                self._flush()
        except BaseException as exc:  # noqa: BLE001 - surfaced by close(), never dropped
            self._thread_error = exc

    def _ignored(self, message: can.Message) -> bool:
        return self._silent or message.is_extended_id or message.is_error_frame or message.is_remote_frame

    def _receive_timeout(self) -> float:
        timeout = 0.02  # real seconds: bounds how long close() waits for the thread
        with self._lock:
            deadline = self._model.next_deadline()
            if deadline is not None:
                timeout = min(timeout, self.clock.to_real(max(deadline - self.clock.now(), 0.0)))
        return max(timeout, 0.001)

    def _flush(self) -> None:
        """Send what the model queued (dropped while the drive is silent)."""
        with self._lock:
            frames, self._model.outbox = self._model.outbox, []
            if self._silent:
                return
        for arbitration_id, data in frames:
            self._bus.send(can.Message(arbitration_id=arbitration_id, data=data, is_extended_id=False))
