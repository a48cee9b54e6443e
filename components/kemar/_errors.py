"""The exception tree of the KEMAR head stack: codec, driver, head logic and simulated drive."""

from __future__ import annotations

__all__ = [
    "KemarError",
    "CodecError",
    "BusError",
    "DriveTimeout",
    "DriveCommandError",
    "SdoAbortError",
    "DriveFault",
    "NotHomed",
    "HomingFailed",
    "MotionStopped",
    "MotionTimeout",
    "InvalidCommand",
    "SimulatedDriveError",
]


class KemarError(Exception):
    """Base class of every error raised by :mod:`aiogenomix.components.kemar`."""


class CodecError(KemarError, ValueError):
    """A frame cannot be encoded or decoded (bad mnemonic, index, value or length)."""


class BusError(KemarError):
    """The CAN bus refused a frame, or the driver is closed."""


class DriveTimeout(KemarError):
    """The drive did not answer a request in time (unplugged, unpowered or not started)."""


class DriveCommandError(KemarError):
    """The drive answered a binary-interpreter request with an error code (EC).

    Attributes:
        mnemonic: The two-letter command that failed, e.g. ``"BG"``.
        index: The array index of the command (0 for scalars).
        code: The Elmo error code carried by the reply.
        meaning: A readable meaning of *code* (``"unknown error code"`` if not tabulated).
    """

    def __init__(self, mnemonic: str, index: int, code: int, meaning: str) -> None:
        self.mnemonic = mnemonic
        self.index = index
        self.code = code
        self.meaning = meaning
        where = f"{mnemonic}[{index}]" if index else mnemonic
        super().__init__(f"drive refused {where}: error code {code} ({meaning})")


class SdoAbortError(KemarError):
    """The drive aborted an SDO transfer.

    Attributes:
        index: Object dictionary index.
        subindex: Object dictionary sub-index.
        code: The CANopen abort code.
    """

    def __init__(self, index: int, subindex: int, code: int, meaning: str) -> None:
        self.index = index
        self.subindex = subindex
        self.code = code
        super().__init__(f"SDO 0x{index:04X}:{subindex} aborted: 0x{code:08X} ({meaning})")


class DriveFault(KemarError):
    """The drive latched a motor fault or reported an emergency; the motor is off.

    Attributes:
        motor_fault: The MF register (0 when only an emergency frame is known).
    """

    def __init__(self, message: str, motor_fault: int = 0) -> None:
        self.motor_fault = motor_fault
        super().__init__(message)


class NotHomed(KemarError):
    """A move was asked before a successful homing: the head has no reference."""


class HomingFailed(KemarError):
    """The homing sequence did not find both limit switches or could not centre the head."""


class MotionStopped(KemarError):
    """A move ended away from its target (stopped by a limit switch or by the drive)."""


class MotionTimeout(KemarError):
    """A move or a homing stage took far longer than its speed and acceleration allow."""


class InvalidCommand(KemarError, ValueError):
    """A head command has an argument out of range (e.g. a speed above the drive's maximum)."""


class SimulatedDriveError(KemarError):
    """The simulated drive's thread stopped on an unexpected error (a bug in the simulator)."""
