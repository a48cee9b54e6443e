"""The state machine of a simulated Elmo Harmonica with the KEMAR head on its motor, sans I/O.

:class:`HarmonicaModel` takes frames and times and produces frames: registers,
unit modes, trapezoidal motion computed analytically in time, hard-stop limit
switches, homing-on-the-fly, error codes, SDO objects and NMT states.  The bus,
the thread and the clock live in :mod:`._simdrive`.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from ._codec import (
    INPUT_FORWARD_LIMIT,
    INPUT_REVERSE_LIMIT,
    NMT_COB_ID,
    CobIds,
    CodecError,
    CommandKind,
    Emergency,
    InterpreterReply,
    InterpreterRequest,
    MotorFault,
    NmtCommand,
    NmtState,
    SdoKind,
    StatusRegister,
    decode_nmt,
    decode_sdo,
    encode_emcy,
    encode_sdo_abort,
    encode_sdo_download_ack,
    encode_sdo_upload_reply,
)
from ._profile import Trajectory, plan_jog, plan_move, plan_stop

__all__ = ["HarmonicaModel", "Frame"]

#: An outgoing frame: (11-bit identifier, payload).
Frame = tuple[int, bytes]

# Interpreter error codes raised by the simulation.
_EC_BAD_COMMAND = 2
_EC_BAD_INDEX = 3
_EC_OUT_OF_RANGE = 21
_EC_NOT_ASSIGNABLE = 23
_EC_MOVING = 25
_EC_MOTOR_MUST_BE_OFF = 57
_EC_MOTOR_MUST_BE_ON = 58
_EC_BAD_UNIT_MODE = 60

# Homing-on-the-fly event codes (HM[3]) for the limit inputs.
_HM_EVENT_IMMEDIATE = 0
_HM_EVENT_FLS = 5
_HM_EVENT_RLS = 7

# Largest speed (counts/s) and rates the simulated drive accepts.
_MAX_SPEED = 2_000_000
_MAX_RATE = 100_000_000

# Index ranges of array commands; scalars accept index 0 only.
_ARRAY_SIZES = {"TR": 2, "XM": 2, "HM": 5, "IL": 16}
_READ_ONLY = frozenset({"VX", "MS", "SR", "MF", "IP", "EC", "IQ"})
_KNOWN = frozenset(
    {"MO", "UM", "PM", "RM", "PA", "PR", "SP", "JV", "AC", "DC", "SD", "PX", "TR", "MI", "XM", "IL", "HM", "TC"}
) | _READ_ONLY

# SDO objects the real host drivers write at initialisation; the simulator
# acknowledges them and reads them back.
_OBJECTS: dict[tuple[int, int], int] = {
    (0x1A00, 0): 0,
    (0x1A00, 1): 0,
    (0x1A00, 2): 0,
    (0x1800, 2): 0xFF,
    (0x1016, 1): 0,
    (0x1029, 1): 0,
    (0x6007, 0): 0,
    (0x2F21, 0): 0,
}


class HarmonicaModel:
    """A Harmonica drive and its head, advanced by explicit times (not thread-safe: lock outside).

    Positions are in encoder counts in the *physical* frame (0 = head straight
    ahead); the drive's PX is that plus an offset, 0 at power-up wherever the
    head stands, until the host zeroes it.

    Args:
        now: The time of power-up.
        node_id: CANopen node id.
        start_position: Physical head position at power-up (counts).
        reverse_switch: Physical position of the reverse limit switch (counts).
        forward_switch: Physical position of the forward limit switch (counts).
        echo_sets: Answer set commands with their echo.
        require_nmt_start: Ignore interpreter frames until an NMT start.
        stuck_timeout: Seconds of commanded motion of a stuck motor before it faults.
    """

    def __init__(
        self,
        now: float,
        *,
        node_id: int,
        start_position: float,
        reverse_switch: float,
        forward_switch: float,
        echo_sets: bool = True,
        require_nmt_start: bool = True,
        stuck_timeout: float = 0.3,
    ) -> None:
        self.cob = CobIds(node_id)
        self.echo_sets = echo_sets
        self.stuck_timeout = stuck_timeout
        #: Whether the motor shaft is blocked (an injected fault).
        self.stuck = False
        #: The share of the commanded speed and accelerations the motor reaches (an injected fault:
        #: a worn gearbox, a load it was not sized for); 1 is nominal.  The drive still reports the
        #: motion as running, so only the host's own deadline notices.
        self.drag = 1.0
        #: Frames to send, oldest first; the owner drains it.
        self.outbox: list[Frame] = []
        self._reverse_switch = reverse_switch
        self._forward_switch = forward_switch
        self._require_nmt_start = require_nmt_start
        self._t_eval = now
        self._trajectory = Trajectory.rest(now, start_position)
        self._offset = -start_position
        self._reset_registers(now)

    # ------------------------------------------------------------------ observation

    def state_at(self, now: float) -> tuple[float, float]:
        """Physical (position, velocity) at *now* (call :meth:`advance` first)."""
        position, velocity, _ = self._trajectory.state_at(now)
        return position, 0.0 if self._stuck_since is not None else velocity

    def encoder(self, position: float) -> int:
        """The PX reading for a physical *position*."""
        return round(position + self._offset)

    @property
    def motor_on(self) -> bool:
        """MO."""
        return bool(self._mo)

    @property
    def unit_mode(self) -> int:
        """UM."""
        return self._um

    @property
    def motor_fault(self) -> int:
        """MF."""
        return self._mf

    def next_deadline(self) -> float | None:
        """When :meth:`advance` must run next without any frame (a stuck motor faulting)."""
        return None if self._stuck_since is None else self._stuck_since + self.stuck_timeout

    def set_stuck(self, stuck: bool, now: float) -> None:
        """Block or free the motor shaft."""
        self.advance(now)
        self.stuck = stuck
        if not stuck:
            self._stuck_since: float | None = None

    def boot(self) -> None:
        """Announce the boot-up (heartbeat state 0)."""
        self._queue(self.cob.heartbeat, bytes((NmtState.BOOT_UP,)))

    # ------------------------------------------------------------------ state

    def _reset_registers(self, now: float) -> None:
        self._nmt = NmtState.PRE_OPERATIONAL if self._require_nmt_start else NmtState.OPERATIONAL
        self._mo = 0
        self._um = 5
        self._pm = 1
        self._rm = 0
        self._pa = 0
        self._pr = 0
        self._sp = 20_000
        self._jv = 0
        self._ac = 300_000
        self._dc = 300_000
        self._sd = 1_000_000
        self._tc = 0.0
        self._mi = 0
        self._ec = 0
        self._mf = 0
        self._tr = [0, 15, 200]
        self._xm = [0, -(1 << 30), 1 << 30]
        self._il = [0] * 17
        self._hm = [0] * 6
        self._motion_command = "PA"
        self._stopped_by_limit = False
        self._stuck_since = None
        self._profile_end = now
        self._objects = dict(_OBJECTS)
        position = self._trajectory.state_at(now)[0]
        self._trajectory = Trajectory.rest(now, position)

    def inputs(self, position: float) -> int:
        bits = 0
        if position >= self._forward_switch - 1e-6:
            bits |= INPUT_FORWARD_LIMIT
        if position <= self._reverse_switch + 1e-6:
            bits |= INPUT_REVERSE_LIMIT
        return bits

    def advance(self, now: float) -> None:
        """Bring the model to *now*: limit-switch stops, homing events, stuck faults."""
        t = self._t_eval
        while t < now and self._trajectory.is_moving(t):
            position = self._trajectory.state_at(t)[0]
            hits: list[tuple[float, int]] = []
            if position < self._forward_switch:
                hit = self._trajectory.first_reach(self._forward_switch, +1, t, now)
                if hit is not None:
                    hits.append((hit, +1))
            if position > self._reverse_switch:
                hit = self._trajectory.first_reach(self._reverse_switch, -1, t, now)
                if hit is not None:
                    hits.append((hit, -1))
            if not hits:
                break
            t, side = min(hits)
            self._on_limit(t, side)
        self._t_eval = max(self._t_eval, now)
        if self._stuck_since is not None and now >= self._stuck_since + self.stuck_timeout:
            self.latch_fault(self._stuck_since + self.stuck_timeout, int(MotorFault.MOTOR_STUCK), 0x7121)

    def _on_limit(self, t: float, side: int) -> None:
        level = self._forward_switch if side > 0 else self._reverse_switch
        event = _HM_EVENT_FLS if side > 0 else _HM_EVENT_RLS
        if self._hm[1] == 1 and self._hm[3] == event:
            self._homing_event(level)
        # The switches are wired as hard stops: the motor stops on the switch.
        self._trajectory = Trajectory.rest(t, level)
        self._profile_end = t
        self._stopped_by_limit = True

    def _homing_event(self, position: float) -> None:
        self._hm[1] = 0  # homing disarms itself when its event fires
        if self._hm[5] == 0:
            self._offset = self._hm[2] - position
        elif self._hm[5] == 1:
            self._offset += self._hm[2]

    def latch_fault(self, t: float, fault: int, emergency_code: int) -> None:
        position = self._trajectory.state_at(t)[0]
        self._trajectory = Trajectory.rest(t, position)
        self._profile_end = t
        self._mo = 0
        self._mf |= fault
        self._stuck_since = None
        self._queue(self.cob.emcy, encode_emcy(Emergency(emergency_code, error_register=0x01)))

    def motion_status(self, now: float) -> int:
        if not self._mo:
            return 1
        if self._stuck_since is not None:
            return 2
        if self._um == 2:
            return 2 if now < self._trajectory.end_time else 1
        if self._trajectory.is_moving(now):
            return 2
        position = self._trajectory.state_at(now)[0] + self._offset
        settled = now - self._profile_end >= self._tr[2] / 1000.0 and abs(position - self._pa) <= self._tr[1]
        return 0 if settled else 1

    def _status_register(self, now: float) -> int:
        return StatusRegister.compose(
            motor_on=bool(self._mo),
            motor_fault=self._mf != 0,
            unit_mode=self._um,
            homing=self._hm[1] == 1,
            motion_status=self.motion_status(now),
            stopped_by_limit=self._stopped_by_limit,
            reference_mode=bool(self._rm),
        ).raw

    # ------------------------------------------------------------------ frames

    def on_frame(self, arbitration_id: int, data: bytes, now: float) -> None:
        """Handle one standard frame from the bus at time *now*; answers go to :attr:`outbox`."""
        try:
            if arbitration_id == NMT_COB_ID:
                self._on_nmt(data, now)
            elif arbitration_id == self.cob.sdo_request and self._nmt != NmtState.STOPPED:
                self._on_sdo(data)
            elif arbitration_id == self.cob.interpreter_request and self._nmt == NmtState.OPERATIONAL:
                reply = self._on_request(InterpreterRequest.decode(data), now)
                if reply is not None:
                    self._queue(self.cob.interpreter_reply, reply.encode())
        except CodecError:
            return  # a real drive ignores frames it cannot parse; the host then times out

    def _queue(self, arbitration_id: int, data: bytes) -> None:
        self.outbox.append((arbitration_id, data))

    def _on_nmt(self, data: bytes, now: float) -> None:
        command, node = decode_nmt(data)
        if node not in (0, self.cob.node):
            return
        if command is NmtCommand.START:
            self._nmt = NmtState.OPERATIONAL
        elif command is NmtCommand.STOP:
            self._nmt = NmtState.STOPPED
        elif command is NmtCommand.PRE_OPERATIONAL:
            self._nmt = NmtState.PRE_OPERATIONAL
        else:
            if command is NmtCommand.RESET_NODE:
                self._reset_registers(now)
            self._nmt = NmtState.PRE_OPERATIONAL
            self._queue(self.cob.heartbeat, bytes((NmtState.BOOT_UP,)))

    def _on_sdo(self, data: bytes) -> None:
        frame = decode_sdo(data, from_server=False)
        key = (frame.index, frame.subindex)
        if key not in self._objects:
            known_index = any(index == frame.index for index, _ in self._objects)
            code = 0x06090011 if known_index else 0x06020000
            self._queue(self.cob.sdo_reply, encode_sdo_abort(frame.index, frame.subindex, code))
        elif frame.kind is SdoKind.DOWNLOAD_REQUEST:
            self._objects[key] = frame.value or 0
            self._queue(self.cob.sdo_reply, encode_sdo_download_ack(frame.index, frame.subindex))
        else:
            value = self._objects[key]
            self._queue(self.cob.sdo_reply, encode_sdo_upload_reply(frame.index, frame.subindex, value))

    def _on_request(self, request: InterpreterRequest, now: float) -> InterpreterReply | None:
        mnemonic, index = request.mnemonic, request.index
        if mnemonic not in _KNOWN and mnemonic not in ("BG", "ST"):
            return self._error(mnemonic, index, _EC_BAD_COMMAND)
        size = _ARRAY_SIZES.get(mnemonic, 0)
        if (size == 0 and index != 0) or (size and not 1 <= index <= size):
            return self._error(mnemonic, index, _EC_BAD_INDEX)
        if request.kind is CommandKind.EXECUTE:
            code = self._execute(mnemonic, now)
            return self._error(mnemonic, index, code) if code else InterpreterReply(mnemonic, index, 0)
        if request.kind is CommandKind.QUERY:
            return InterpreterReply(mnemonic, index, self._query(mnemonic, index, now))
        assert request.value is not None
        if mnemonic in _READ_ONLY:
            return self._error(mnemonic, index, _EC_NOT_ASSIGNABLE)
        code = self._assign(mnemonic, index, request.value, now)
        if code:
            return self._error(mnemonic, index, code)
        return InterpreterReply(mnemonic, index, request.value) if self.echo_sets else None

    def _error(self, mnemonic: str, index: int, code: int) -> InterpreterReply:
        self._ec = code
        return InterpreterReply(mnemonic, index, None, code)

    def _query(self, mnemonic: str, index: int, now: float) -> int | float:
        position, velocity, acceleration = self._trajectory.state_at(now)
        if self._stuck_since is not None:
            velocity = acceleration = 0.0
        values: dict[str, Callable[[], int | float]] = {
            "MO": lambda: self._mo,
            "UM": lambda: self._um,
            "PM": lambda: self._pm,
            "RM": lambda: self._rm,
            "PA": lambda: self._pa,
            "PR": lambda: self._pr,
            "SP": lambda: self._sp,
            "JV": lambda: self._jv,
            "AC": lambda: self._ac,
            "DC": lambda: self._dc,
            "SD": lambda: self._sd,
            "PX": lambda: round(position + self._offset),
            "VX": lambda: round(velocity),
            "MS": lambda: self.motion_status(now),
            "SR": lambda: self._status_register(now),
            "MF": lambda: self._mf,
            "IP": lambda: self.inputs(position),
            "EC": lambda: self._ec,
            "MI": lambda: self._mi,
            "TR": lambda: self._tr[index],
            "XM": lambda: self._xm[index],
            "IL": lambda: self._il[index],
            "HM": lambda: self._hm[index],
            # A crude current model: holding current plus a share for acceleration.
            "IQ": lambda: float(0.2 * self._mo + abs(acceleration) / max(self._ac, 1) * 2.0),
            "TC": lambda: self._tc,
        }
        return values[mnemonic]()

    def _assign(self, mnemonic: str, index: int, value: int | float, now: float) -> int:
        """Apply a set command; return an error code, or 0."""
        if mnemonic == "TC":
            self._tc = float(value)
            return 0
        number = round(value)
        if mnemonic == "MO":
            return self._set_motor(number, now)
        if mnemonic == "UM":
            if self._mo:
                return _EC_MOTOR_MUST_BE_OFF
            if number not in (1, 2, 3, 4, 5):
                return _EC_OUT_OF_RANGE
            self._um = number
        elif mnemonic in ("PM", "RM"):
            if number not in (0, 1):
                return _EC_OUT_OF_RANGE
            setattr(self, f"_{mnemonic.lower()}", number)
        elif mnemonic in ("PA", "PR"):
            setattr(self, f"_{mnemonic.lower()}", number)
            self._motion_command = mnemonic
        elif mnemonic == "JV":
            if abs(number) > _MAX_SPEED:
                return _EC_OUT_OF_RANGE
            self._jv = number
            self._motion_command = "JV"
        elif mnemonic == "SP":
            if not 0 < number <= _MAX_SPEED:
                return _EC_OUT_OF_RANGE
            self._sp = number
        elif mnemonic in ("AC", "DC", "SD"):
            if not 0 < number <= _MAX_RATE:
                return _EC_OUT_OF_RANGE
            setattr(self, f"_{mnemonic.lower()}", number)
        elif mnemonic == "PX":
            if self._trajectory.is_moving(now):
                return _EC_MOVING
            self._offset = number - self._trajectory.state_at(now)[0]
        elif mnemonic == "MI":
            self._mi = number
        elif mnemonic in ("TR", "XM", "IL"):
            getattr(self, f"_{mnemonic.lower()}")[index] = number
        elif mnemonic == "HM":
            return self._set_homing(index, number, now)
        return 0

    def _set_motor(self, value: int, now: float) -> int:
        if value not in (0, 1):
            return _EC_OUT_OF_RANGE
        position = self._trajectory.state_at(now)[0]
        # Motor off drops the load at once; motor on holds the present position.
        self._trajectory = Trajectory.rest(now, position)
        self._profile_end = now
        self._stuck_since = None
        if value and not self._mo:
            self._mf = 0  # MO=1 clears a latched fault
            self._pa = round(position + self._offset)
        self._mo = value
        return 0

    def _set_homing(self, index: int, value: int, now: float) -> int:
        if index == 1:
            if value not in (0, 1):
                return _EC_OUT_OF_RANGE
            self._hm[1] = value
            if value == 1 and self._hm[3] == _HM_EVENT_IMMEDIATE:
                self._homing_event(self._trajectory.state_at(now)[0])
            return 0
        if self._hm[1] == 1:
            return 71  # homing is busy: parameters are frozen while armed
        self._hm[index] = value
        return 0

    def _execute(self, mnemonic: str, now: float) -> int:
        position, velocity, _ = self._trajectory.state_at(now)
        if mnemonic == "ST":
            if self._trajectory.is_moving(now):
                self._trajectory = plan_stop(now, position, velocity, self._sd)
                self._profile_end = self._trajectory.end_time
            self._stuck_since = None
            return 0
        if not self._mo:
            return _EC_MOTOR_MUST_BE_ON
        if self._um not in (2, 5):
            return _EC_BAD_UNIT_MODE
        if self.stuck:
            self._stuck_since = now if self._stuck_since is None else self._stuck_since
            return 0
        if self._um == 2 or self._motion_command == "JV":
            trajectory = plan_jog(now, position, velocity, self._jv * self.drag, self._ac * self.drag,
                                  self._dc * self.drag)
            direction = math.copysign(1.0, self._jv) if self._jv else 0.0
        else:
            if self._motion_command == "PR":
                self._pa = self._pa + self._pr
                self._motion_command = "PA"
            target = self._pa - self._offset
            trajectory = plan_move(now, position, velocity, target, self._sp * self.drag, self._ac * self.drag,
                                   self._dc * self.drag)
            direction = math.copysign(1.0, target - position) if target != position else 0.0
        inputs = self.inputs(position)
        if (direction > 0 and inputs & INPUT_FORWARD_LIMIT) or (direction < 0 and inputs & INPUT_REVERSE_LIMIT):
            # A hard-stop input inhibits motion towards its side.
            self._trajectory = Trajectory.rest(now, position)
            self._stopped_by_limit = True
            return 0
        self._stopped_by_limit = False
        self._trajectory = trajectory
        self._profile_end = trajectory.end_time
        return 0
