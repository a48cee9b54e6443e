"""Decoders of the drive's status registers: SR and MF bit by bit, in readable text, and the IP limit bits."""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = ["StatusRegister", "MotorFault", "describe_motor_fault", "INPUT_FORWARD_LIMIT", "INPUT_REVERSE_LIMIT"]

#: IP bit of the forward limit switch (FLS) on the KEMAR rig.
INPUT_FORWARD_LIMIT = 1 << 10
#: IP bit of the reverse limit switch (RLS) on the KEMAR rig.
INPUT_REVERSE_LIMIT = 1 << 11

# Servo status codes, as found in SR bits 1-3 and MF bits 13-15.
_SERVO_STATUS: dict[int, str] = {
    1: "under-voltage",
    2: "over-voltage",
    5: "short circuit",
    6: "over-temperature",
}


@dataclass(frozen=True)
class StatusRegister:
    """The SR register, bit by bit (SimplIQ command reference, SR page).

    Attributes:
        raw: The register as an unsigned 32-bit integer.
    """

    raw: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "raw", self.raw & 0xFFFFFFFF)

    def _bit(self, bit: int) -> bool:
        return bool(self.raw >> bit & 1)

    @property
    def drive_problem(self) -> bool:
        """Bit 0: the servo drive reports a problem (details in :attr:`servo_status`)."""
        return self._bit(0)

    @property
    def servo_status(self) -> int:
        """Bits 1-3: 0 OK, 1 under-voltage, 2 over-voltage, 5 short circuit, 6 over-temperature."""
        return self.raw >> 1 & 0x7

    @property
    def motor_on(self) -> bool:
        """Bit 4: the motor is enabled (MO=1)."""
        return self._bit(4)

    @property
    def reference_mode(self) -> bool:
        """Bit 5: reference mode (RM) on."""
        return self._bit(5)

    @property
    def motor_fault(self) -> bool:
        """Bit 6: a motor failure is latched (see MF)."""
        return self._bit(6)

    @property
    def unit_mode(self) -> int:
        """Bits 7-9: the unit mode (UM)."""
        return self.raw >> 7 & 0x7

    @property
    def homing(self) -> bool:
        """Bit 11: main or auxiliary homing armed."""
        return self._bit(11)

    @property
    def program_running(self) -> bool:
        """Bit 12: a user program is running."""
        return self._bit(12)

    @property
    def current_limited(self) -> bool:
        """Bit 13: current limit on."""
        return self._bit(13)

    @property
    def motion_status(self) -> int:
        """Bits 14-15: reflection of MS (0 settled, 1 stationary/off, 2 moving)."""
        return self.raw >> 14 & 0x3

    @property
    def cpu_fault(self) -> bool:
        """Bit 27: CPU exception or stack overflow."""
        return self._bit(27)

    @property
    def stopped_by_limit(self) -> bool:
        """Bit 28: motion was stopped by a limit switch or a stop input."""
        return self._bit(28)

    @property
    def program_error(self) -> bool:
        """Bit 29: error in the user program."""
        return self._bit(29)

    @classmethod
    def compose(
        cls,
        *,
        motor_on: bool = False,
        motor_fault: bool = False,
        unit_mode: int = 5,
        homing: bool = False,
        motion_status: int = 0,
        stopped_by_limit: bool = False,
        servo_status: int = 0,
        reference_mode: bool = False,
    ) -> StatusRegister:
        """Build a register from its fields (used by the simulated drive)."""
        raw = (
            (1 if servo_status else 0)
            | (servo_status & 0x7) << 1
            | int(motor_on) << 4
            | int(reference_mode) << 5
            | int(motor_fault) << 6
            | (unit_mode & 0x7) << 7
            | int(homing) << 11
            | (motion_status & 0x3) << 14
            | int(stopped_by_limit) << 28
        )
        return cls(raw)

    def describe(self) -> str:
        """Return a readable summary, e.g. ``"motor on, UM=5, moving"``."""
        parts = ["motor on" if self.motor_on else "motor off", f"UM={self.unit_mode}"]
        parts.append({0: "settled", 1: "stationary", 2: "moving"}.get(self.motion_status, "MS=3"))
        if self.drive_problem:
            parts.append("drive problem: " + _SERVO_STATUS.get(self.servo_status, f"code {self.servo_status}"))
        if self.motor_fault:
            parts.append("motor fault latched")
        if self.homing:
            parts.append("homing armed")
        if self.stopped_by_limit:
            parts.append("stopped by a limit")
        if self.current_limited:
            parts.append("current limited")
        if self.cpu_fault:
            parts.append("CPU fault")
        if self.program_error:
            parts.append("user program error")
        return ", ".join(parts)


class MotorFault(enum.IntFlag):
    """The MF register's single-bit faults (bits 13-15 are a code, see :func:`describe_motor_fault`)."""

    NONE = 0
    FEEDBACK_NOT_READY = 0x1
    FEEDBACK_LOSS = 0x4
    PEAK_CURRENT = 0x8
    INHIBIT = 0x10
    HALLS_CHANGED = 0x40
    SPEED_TRACKING = 0x80
    POSITION_TRACKING = 0x100
    INCONSISTENT_DATABASE = 0x200
    HEARTBEAT_FAILURE = 0x800
    SERVO_DRIVE_FAULT = 0x1000
    ELECTRICAL_ZERO_NOT_FOUND = 0x10000
    SPEED_LIMIT = 0x20000
    STACK_OVERFLOW = 0x40000
    CPU_EXCEPTION = 0x80000
    MOTOR_STUCK = 0x200000
    POSITION_LIMIT = 0x400000
    CANNOT_START = 0x20000000


_MOTOR_FAULT_TEXT: dict[MotorFault, str] = {
    MotorFault.FEEDBACK_NOT_READY: "resolver or analog Hall not ready",
    MotorFault.FEEDBACK_LOSS: "feedback loss",
    MotorFault.PEAK_CURRENT: "peak current exceeded",
    MotorFault.INHIBIT: "inhibit input",
    MotorFault.HALLS_CHANGED: "two Hall sensors changed at once",
    MotorFault.SPEED_TRACKING: "speed tracking error",
    MotorFault.POSITION_TRACKING: "position tracking error",
    MotorFault.INCONSISTENT_DATABASE: "inconsistent database",
    MotorFault.HEARTBEAT_FAILURE: "CAN heartbeat failure",
    MotorFault.ELECTRICAL_ZERO_NOT_FOUND: "electrical zero not found",
    MotorFault.SPEED_LIMIT: "speed limit exceeded",
    MotorFault.STACK_OVERFLOW: "stack overflow",
    MotorFault.CPU_EXCEPTION: "CPU exception",
    MotorFault.MOTOR_STUCK: "motor stuck",
    MotorFault.POSITION_LIMIT: "position limit exceeded",
    MotorFault.CANNOT_START: "cannot start motor",
}


def describe_motor_fault(mf: int) -> str:
    """Return the readable faults of an MF register value (``"no fault"`` for 0)."""
    mf &= 0xFFFFFFFF
    if mf == 0:
        return "no fault"
    texts = [text for flag, text in _MOTOR_FAULT_TEXT.items() if mf & flag]
    if mf & MotorFault.SERVO_DRIVE_FAULT:
        code = mf >> 13 & 0x7
        texts.append("servo drive fault: " + _SERVO_STATUS.get(code, f"code {code}"))
    known = sum(_MOTOR_FAULT_TEXT) | MotorFault.SERVO_DRIVE_FAULT | 0xE000
    if mf & ~known:
        texts.append(f"other bits 0x{mf & ~known:08X}")
    return ", ".join(texts)
