"""The KEMAR head over CAN: the component, its driver, and the simulated Elmo drive it is tested against.

Layers, bottom up: a private codec of the Elmo binary interpreter (frames, sans
I/O) → :class:`HarmonicaDriver` (python-can, asyncio) → :class:`KemarHead`
(homing, position and velocity control) → :class:`Kemar` (the genom3-like
component).  :class:`SimulatedHarmonica` is a drive that sits on the far end of
the same bus.  The codec and the motion profiles stay private: what a user
handles are the driver's commands (:class:`NmtCommand`), its emergency reports
(:class:`Emergency`) and the faults a simulated drive can be made to raise
(:class:`MotorFault`).
"""

from ._codec import Emergency, MotorFault, NmtCommand, NmtState
from ._component import SIMULATED_BUS, Kemar, parse_bus, simulated_rig
from ._driver import EmergencyListener, HarmonicaDriver
from ._errors import (
    BusError, CodecError, DriveCommandError, DriveFault, DriveTimeout, HomingFailed, InvalidCommand, KemarError,
    MotionStopped, MotionTimeout, NotHomed, SdoAbortError, SimulatedDriveError,
)
from ._head import HeadConfig, HeadState, KemarHead, MotionType
from ._simdrive import COUNTS_PER_DEGREE, DEFAULT_NODE_ID, DriveSnapshot, SimulatedHarmonica
from ._types import (
    BUS_ERROR, BUS_TIMEOUT, DRIVE_ERROR, DRIVE_FAULT, HOMING_FAILED, INVALID_TARGET, INVALID_VELOCITY,
    MOTION_STOPPED, NOT_HOMED, KemarState, Timestamp,
)

__all__ = [
    # The component and its wire types
    "Kemar", "KemarState", "Timestamp", "simulated_rig", "parse_bus", "SIMULATED_BUS",
    "NOT_HOMED", "INVALID_TARGET", "INVALID_VELOCITY", "DRIVE_FAULT", "BUS_TIMEOUT", "BUS_ERROR", "DRIVE_ERROR",
    "HOMING_FAILED", "MOTION_STOPPED",
    # Head logic
    "KemarHead", "HeadConfig", "HeadState", "MotionType",
    # The driver: its commands and emergency reports
    "HarmonicaDriver", "EmergencyListener", "NmtCommand", "NmtState", "Emergency",
    # The simulated drive, and the faults it can be made to raise
    "SimulatedHarmonica", "DriveSnapshot", "MotorFault", "COUNTS_PER_DEGREE", "DEFAULT_NODE_ID",
    # Errors
    "KemarError", "CodecError", "BusError", "DriveTimeout", "DriveCommandError", "SdoAbortError", "DriveFault",
    "NotHomed", "HomingFailed", "MotionStopped", "MotionTimeout", "InvalidCommand", "SimulatedDriveError",
]
