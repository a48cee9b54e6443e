"""The KEMAR head over CAN: Elmo binary-interpreter codec, asyncio driver, simulated drive, head logic, component.

Layers, bottom up: :mod:`._codec` (frames, sans I/O) → :class:`HarmonicaDriver`
(python-can, asyncio) → :class:`KemarHead` (homing, position and velocity
control) → :class:`Kemar` (the genom3-like component).  :class:`SimulatedHarmonica`
is a drive that sits on the far end of the same bus.
"""

from ._codec import (
    EMCY_CODES, ERROR_CODES, INPUT_FORWARD_LIMIT, INPUT_REVERSE_LIMIT, CobIds, CommandKind, Emergency,
    InterpreterReply, InterpreterRequest, MotorFault, NmtCommand, NmtState, SdoFrame, SdoKind, StatusRegister,
    decode_emcy, decode_nmt, decode_reply, decode_sdo, describe_motor_fault, encode_emcy, encode_execute,
    encode_nmt, encode_query, encode_sdo_abort, encode_sdo_download, encode_sdo_download_ack,
    encode_sdo_upload_reply, encode_sdo_upload_request, encode_set, error_code_meaning,
)
from ._component import RIG_KEY, Kemar, parse_bus, simulated_rig
from ._driver import EmergencyListener, HarmonicaDriver
from ._errors import (
    BusError, CodecError, DriveCommandError, DriveFault, DriveTimeout, HomingFailed, InvalidCommand, KemarError,
    MotionStopped, MotionTimeout, NotHomed, SdoAbortError, SimulatedDriveError,
)
from ._head import HeadConfig, HeadState, KemarHead, MotionType
from ._profile import Trajectory, move_duration, plan_jog, plan_move, plan_stop
from ._simdrive import COUNTS_PER_DEGREE, DEFAULT_NODE_ID, DriveSnapshot, SimulatedHarmonica
from ._types import (
    BUS_ERROR, BUS_TIMEOUT, DRIVE_ERROR, DRIVE_FAULT, HOMING_FAILED, INVALID_TARGET, INVALID_VELOCITY,
    MOTION_STOPPED, NOT_HOMED, KemarState, Timestamp,
)

__all__ = [
    # The component and its wire types
    "Kemar", "KemarState", "Timestamp", "simulated_rig", "parse_bus", "RIG_KEY",
    "NOT_HOMED", "INVALID_TARGET", "INVALID_VELOCITY", "DRIVE_FAULT", "BUS_TIMEOUT", "BUS_ERROR", "DRIVE_ERROR",
    "HOMING_FAILED", "MOTION_STOPPED",
    # Head logic
    "KemarHead", "HeadConfig", "HeadState", "MotionType",
    # Driver and simulated drive
    "HarmonicaDriver", "EmergencyListener", "SimulatedHarmonica", "DriveSnapshot", "COUNTS_PER_DEGREE",
    "DEFAULT_NODE_ID",
    # Codec
    "CobIds", "CommandKind", "InterpreterRequest", "InterpreterReply", "encode_set", "encode_query",
    "encode_execute", "decode_reply", "ERROR_CODES", "error_code_meaning", "NmtCommand", "NmtState", "encode_nmt",
    "decode_nmt", "SdoKind", "SdoFrame", "encode_sdo_download", "encode_sdo_upload_request",
    "encode_sdo_download_ack", "encode_sdo_upload_reply", "encode_sdo_abort", "decode_sdo", "Emergency",
    "EMCY_CODES", "encode_emcy", "decode_emcy", "StatusRegister", "MotorFault", "describe_motor_fault",
    "INPUT_FORWARD_LIMIT", "INPUT_REVERSE_LIMIT",
    # Motion profiles
    "Trajectory", "plan_move", "plan_jog", "plan_stop", "move_duration",
    # Errors
    "KemarError", "CodecError", "BusError", "DriveTimeout", "DriveCommandError", "SdoAbortError", "DriveFault",
    "NotHomed", "HomingFailed", "MotionStopped", "MotionTimeout", "InvalidCommand", "SimulatedDriveError",
]
