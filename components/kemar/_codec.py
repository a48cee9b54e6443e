"""Sans-I/O codec for Elmo binary-interpreter frames and the few CANopen frames of the KEMAR drive.

Byte layouts follow the Elmo *CANopen DS 301 Implementation Guide* (binary
interpreter, chapter 9) and CiA 301 (NMT, expedited SDO, EMCY).  Nothing here
touches a bus: every function maps bytes to values and back, so the driver and
the simulated drive share one tested implementation.  The SR/MF/IP register
decoders live in :mod:`._registers` and are re-exported here.
"""

from __future__ import annotations

import enum
import math
import struct
from dataclasses import dataclass

from ._errors import CodecError
from ._registers import INPUT_FORWARD_LIMIT, INPUT_REVERSE_LIMIT, MotorFault, StatusRegister, describe_motor_fault

__all__ = [
    "CobIds",
    "CommandKind",
    "InterpreterRequest",
    "InterpreterReply",
    "EXECUTE_COMMANDS",
    "ERROR_CODES",
    "error_code_meaning",
    "encode_set",
    "encode_query",
    "encode_execute",
    "decode_reply",
    "NmtCommand",
    "NmtState",
    "encode_nmt",
    "decode_nmt",
    "SdoKind",
    "SdoFrame",
    "SDO_ABORT_CODES",
    "encode_sdo_download",
    "encode_sdo_upload_request",
    "encode_sdo_download_ack",
    "encode_sdo_upload_reply",
    "encode_sdo_abort",
    "decode_sdo",
    "Emergency",
    "EMCY_CODES",
    "encode_emcy",
    "decode_emcy",
    "StatusRegister",
    "MotorFault",
    "describe_motor_fault",
    "INPUT_FORWARD_LIMIT",
    "INPUT_REVERSE_LIMIT",
]

# --------------------------------------------------------------------------- COB-IDs

NMT_COB_ID = 0x000


@dataclass(frozen=True)
class CobIds:
    """The 11-bit CAN identifiers of one drive (CANopen pre-defined connection set).

    Args:
        node: The CANopen node id (1..127; the KEMAR drive is 0x7F).
    """

    node: int

    def __post_init__(self) -> None:
        if not 1 <= self.node <= 127:
            raise CodecError(f"CANopen node id must be 1..127, not {self.node}")

    @property
    def emcy(self) -> int:
        """Emergency frames, drive → host."""
        return 0x080 + self.node

    @property
    def interpreter_reply(self) -> int:
        """TPDO2: binary-interpreter replies, drive → host."""
        return 0x280 + self.node

    @property
    def interpreter_request(self) -> int:
        """RPDO2: binary-interpreter requests, host → drive."""
        return 0x300 + self.node

    @property
    def sdo_reply(self) -> int:
        """SDO server → client."""
        return 0x580 + self.node

    @property
    def sdo_request(self) -> int:
        """SDO client → server."""
        return 0x600 + self.node

    @property
    def heartbeat(self) -> int:
        """Heartbeat / boot-up, drive → host."""
        return 0x700 + self.node


# --------------------------------------------------------------------------- binary interpreter

_QUERY_FLAG = 0x40  # byte 3 bit 6 of a request: DLC-8 query
_ERROR_FLAG = 0x40  # byte 3 bit 6 of a reply: the value bytes carry an error code
_FLOAT_FLAG = 0x80  # byte 3 bit 7: the value is an IEEE float32
_INDEX_MAX = (1 << 14) - 1

#: Commands that are executed rather than set or queried (a DLC-4 frame is then
#: an execution, not a query).
EXECUTE_COMMANDS: frozenset[str] = frozenset({"BG", "ST"})

#: Elmo interpreter error codes (EC) and their meaning.  2, 3, 5, 6, 7, 11 come
#: from the SimplIQ command reference, 21 and 58 from the DS 301 guide examples;
#: the others are the usual SimplIQ table as quoted by several drivers.
ERROR_CODES: dict[int, str] = {
    2: "bad command",
    3: "bad index",
    5: "command has no interpreter meaning",
    6: "program not running",
    7: "mode cannot be started",
    11: "flash write error",
    21: "operand out of range",
    23: "command cannot be assigned",
    25: "command not valid while moving",
    57: "motor must be off",
    58: "motor must be on",
    60: "bad unit mode",
    71: "homing is busy",
}


def error_code_meaning(code: int) -> str:
    """Return the readable meaning of an Elmo interpreter error code."""
    return ERROR_CODES.get(code, "unknown error code")


class CommandKind(enum.Enum):
    """What a binary-interpreter request asks the drive to do."""

    SET = "set"
    QUERY = "query"
    EXECUTE = "execute"


def _check_mnemonic(mnemonic: str) -> str:
    upper = mnemonic.upper()
    if len(upper) != 2 or not upper.isascii() or not upper.isalpha():
        raise CodecError(f"an interpreter mnemonic is two ASCII letters, not {mnemonic!r}")
    return upper


def _header(mnemonic: str, index: int, flags: int) -> bytes:
    upper = _check_mnemonic(mnemonic)
    if not 0 <= index <= _INDEX_MAX:
        raise CodecError(f"interpreter index must be 0..{_INDEX_MAX}, not {index}")
    return bytes((ord(upper[0]), ord(upper[1]), index & 0xFF, (index >> 8) & 0x3F | flags))


def _pack_value(value: int | float) -> tuple[bytes, int]:
    """Return the four value bytes and the type flag for *value*."""
    if isinstance(value, bool) or isinstance(value, int):
        number = int(value)
        # Accept the unsigned spelling of 32-bit registers (masks like MI=0xFFFF...).
        if not -(1 << 31) <= number < (1 << 32):
            raise CodecError(f"interpreter integer {number} does not fit in 32 bits")
        return struct.pack("<I", number & 0xFFFFFFFF), 0
    if isinstance(value, float):
        if not math.isfinite(value):
            raise CodecError(f"interpreter float must be finite, not {value}")
        try:
            return struct.pack("<f", value), _FLOAT_FLAG
        except OverflowError as exc:
            raise CodecError(f"interpreter float {value} does not fit in float32") from exc
    raise CodecError(f"interpreter values are int or float, not {type(value).__name__}")


def _unpack_value(raw: bytes, is_float: bool) -> int | float:
    if is_float:
        return float(struct.unpack("<f", raw)[0])
    return int(struct.unpack("<i", raw)[0])


@dataclass(frozen=True)
class InterpreterRequest:
    """One binary-interpreter request (host → drive, RPDO2).

    Attributes:
        kind: Set, query or execute.
        mnemonic: Two upper-case letters, e.g. ``"PX"``.
        index: Array index (0 for scalar commands).
        value: The value of a set (``None`` for queries and executions).
    """

    kind: CommandKind
    mnemonic: str
    index: int = 0
    value: int | float | None = None

    def encode(self, *, long_query: bool = False) -> bytes:
        """Return the frame payload (DLC 8 for sets, 4 for queries and executions).

        Args:
            long_query: Encode a query as the DLC-8 form with the query flag.
        """
        if self.kind is CommandKind.SET:
            if self.value is None:
                raise CodecError(f"a set of {self.mnemonic} needs a value")
            raw, flag = _pack_value(self.value)
            return _header(self.mnemonic, self.index, flag) + raw
        if self.kind is CommandKind.QUERY and long_query:
            return _header(self.mnemonic, self.index, _QUERY_FLAG) + bytes(4)
        return _header(self.mnemonic, self.index, 0)

    @classmethod
    def decode(cls, data: bytes | bytearray) -> InterpreterRequest:
        """Parse a request payload, as the drive does.

        A DLC-4 frame is a query unless its mnemonic is an execute command; a
        DLC-8 frame is a query when byte 3 bit 6 is set, else a set (or an
        execution for execute commands).

        Raises:
            CodecError: The payload is not 4 or 8 bytes or the mnemonic is not two letters.
        """
        data = bytes(data)
        if len(data) not in (4, 8):
            raise CodecError(f"an interpreter request has 4 or 8 bytes, not {len(data)}")
        mnemonic = _check_mnemonic(data[:2].decode("ascii", errors="replace"))
        index = data[2] | (data[3] & 0x3F) << 8
        if mnemonic in EXECUTE_COMMANDS:
            return cls(CommandKind.EXECUTE, mnemonic, index)
        if len(data) == 4 or data[3] & _QUERY_FLAG:
            return cls(CommandKind.QUERY, mnemonic, index)
        return cls(CommandKind.SET, mnemonic, index, _unpack_value(data[4:8], bool(data[3] & _FLOAT_FLAG)))


@dataclass(frozen=True)
class InterpreterReply:
    """One binary-interpreter reply (drive → host, TPDO2, always DLC 8).

    Attributes:
        mnemonic: Echo of the request's mnemonic.
        index: Echo of the request's index.
        value: The set echo or query result (``None`` for an error reply).
        error_code: The Elmo EC code of an error reply, else ``None``.
    """

    mnemonic: str
    index: int = 0
    value: int | float | None = 0
    error_code: int | None = None

    @property
    def is_error(self) -> bool:
        """Whether the drive refused the request."""
        return self.error_code is not None

    def encode(self) -> bytes:
        """Return the 8-byte reply payload."""
        if self.error_code is not None:
            if not 0 <= self.error_code < (1 << 32):
                raise CodecError(f"error code {self.error_code} does not fit in 32 bits")
            return _header(self.mnemonic, self.index, _ERROR_FLAG) + struct.pack("<I", self.error_code)
        raw, flag = _pack_value(0 if self.value is None else self.value)
        return _header(self.mnemonic, self.index, flag) + raw

    @classmethod
    def decode(cls, data: bytes | bytearray) -> InterpreterReply:
        """Parse a reply payload.

        Raises:
            CodecError: The payload is not 8 bytes or the mnemonic is not two letters.
        """
        data = bytes(data)
        if len(data) != 8:
            raise CodecError(f"an interpreter reply has 8 bytes, not {len(data)}")
        mnemonic = _check_mnemonic(data[:2].decode("ascii", errors="replace"))
        index = data[2] | (data[3] & 0x3F) << 8
        if data[3] & _ERROR_FLAG:
            return cls(mnemonic, index, None, struct.unpack("<I", data[4:8])[0])
        return cls(mnemonic, index, _unpack_value(data[4:8], bool(data[3] & _FLOAT_FLAG)))


def encode_set(mnemonic: str, value: int | float, index: int = 0) -> bytes:
    """Encode ``mnemonic[index]=value``; the Python type of *value* chooses int32 or float32."""
    return InterpreterRequest(CommandKind.SET, mnemonic, index, value).encode()


def encode_query(mnemonic: str, index: int = 0, *, long_query: bool = False) -> bytes:
    """Encode a query of ``mnemonic[index]`` (DLC 4, or DLC 8 with the query flag)."""
    return InterpreterRequest(CommandKind.QUERY, mnemonic, index).encode(long_query=long_query)


def encode_execute(mnemonic: str, index: int = 0) -> bytes:
    """Encode an execute command such as ``BG`` (DLC 4)."""
    return InterpreterRequest(CommandKind.EXECUTE, mnemonic, index).encode()


def decode_reply(data: bytes | bytearray) -> InterpreterReply:
    """Decode a TPDO2 reply payload (see :meth:`InterpreterReply.decode`)."""
    return InterpreterReply.decode(data)


# --------------------------------------------------------------------------- NMT


class NmtCommand(enum.IntEnum):
    """NMT command specifiers (first byte of a COB-ID 0 frame)."""

    START = 0x01
    STOP = 0x02
    PRE_OPERATIONAL = 0x80
    RESET_NODE = 0x81
    RESET_COMMUNICATION = 0x82


class NmtState(enum.IntEnum):
    """Node states as carried by heartbeat / boot-up frames."""

    BOOT_UP = 0x00
    STOPPED = 0x04
    OPERATIONAL = 0x05
    PRE_OPERATIONAL = 0x7F


def encode_nmt(command: NmtCommand, node: int) -> bytes:
    """Encode an NMT frame for *node* (0 addresses every node)."""
    if not 0 <= node <= 127:
        raise CodecError(f"NMT node must be 0..127, not {node}")
    return bytes((int(command), node))


def decode_nmt(data: bytes | bytearray) -> tuple[NmtCommand, int]:
    """Decode an NMT frame into (command, node).

    Raises:
        CodecError: Wrong length or unknown command specifier.
    """
    if len(data) != 2:
        raise CodecError(f"an NMT frame has 2 bytes, not {len(data)}")
    try:
        return NmtCommand(data[0]), data[1]
    except ValueError as exc:
        raise CodecError(f"unknown NMT command 0x{data[0]:02X}") from exc


# --------------------------------------------------------------------------- expedited SDO


class SdoKind(enum.Enum):
    """The expedited SDO frames this package speaks."""

    DOWNLOAD_REQUEST = "download request"
    UPLOAD_REQUEST = "upload request"
    DOWNLOAD_ACK = "download ack"
    UPLOAD_REPLY = "upload reply"
    ABORT = "abort"


#: CiA 301 SDO abort codes used here.
SDO_ABORT_CODES: dict[int, str] = {
    0x05030000: "toggle bit not alternated",
    0x05040000: "SDO protocol timed out",
    0x05040001: "command specifier not valid or unknown",
    0x06010000: "unsupported access to an object",
    0x06020000: "object does not exist in the object dictionary",
    0x06090011: "sub-index does not exist",
    0x08000000: "general error",
    0x08000020: "data cannot be transferred or stored",
}


@dataclass(frozen=True)
class SdoFrame:
    """A decoded expedited SDO frame.

    Attributes:
        kind: Which SDO frame this is.
        index: Object dictionary index.
        subindex: Object dictionary sub-index.
        value: The data of a download request or upload reply (unsigned), else ``None``.
        size: The number of data bytes of *value* (1..4), else ``None``.
        abort_code: The abort code of an abort frame, else ``None``.
    """

    kind: SdoKind
    index: int
    subindex: int
    value: int | None = None
    size: int | None = None
    abort_code: int | None = None


def _sdo_address(index: int, subindex: int) -> bytes:
    if not 0 <= index <= 0xFFFF or not 0 <= subindex <= 0xFF:
        raise CodecError(f"bad object address 0x{index:X}:{subindex}")
    return struct.pack("<HB", index, subindex)


def _sdo_data(value: int, size: int) -> bytes:
    if size not in (1, 2, 3, 4):
        raise CodecError(f"an expedited SDO carries 1..4 bytes, not {size}")
    if not -(1 << (8 * size - 1)) <= value < (1 << (8 * size)):
        raise CodecError(f"value {value} does not fit in {size} bytes")
    return (value & ((1 << (8 * size)) - 1)).to_bytes(size, "little") + bytes(4 - size)


def encode_sdo_download(index: int, subindex: int, value: int, size: int = 4) -> bytes:
    """Encode an expedited download (write) request: 0x23/0x27/0x2B/0x2F for 4/3/2/1 bytes."""
    command = 0x23 | (4 - size) << 2 if size in (1, 2, 3, 4) else 0
    return bytes((command,)) + _sdo_address(index, subindex) + _sdo_data(value, size)


def encode_sdo_upload_request(index: int, subindex: int) -> bytes:
    """Encode an upload (read) request (command 0x40)."""
    return b"\x40" + _sdo_address(index, subindex) + bytes(4)


def encode_sdo_download_ack(index: int, subindex: int) -> bytes:
    """Encode the server's download acknowledgement (command 0x60)."""
    return b"\x60" + _sdo_address(index, subindex) + bytes(4)


def encode_sdo_upload_reply(index: int, subindex: int, value: int, size: int = 4) -> bytes:
    """Encode the server's expedited upload reply: 0x43/0x47/0x4B/0x4F for 4/3/2/1 bytes."""
    command = 0x43 | (4 - size) << 2 if size in (1, 2, 3, 4) else 0
    return bytes((command,)) + _sdo_address(index, subindex) + _sdo_data(value, size)


def encode_sdo_abort(index: int, subindex: int, code: int) -> bytes:
    """Encode an abort frame (command 0x80 + 32-bit abort code), from either side."""
    return b"\x80" + _sdo_address(index, subindex) + struct.pack("<I", code & 0xFFFFFFFF)


def decode_sdo(data: bytes | bytearray, *, from_server: bool) -> SdoFrame:
    """Decode an expedited SDO frame.

    Args:
        data: The 8-byte payload.
        from_server: True for frames on the drive → host COB-ID (0x580+n), whose
            command specifiers differ from the requests'.

    Raises:
        CodecError: Wrong length, segmented transfer or unknown command specifier.
    """
    data = bytes(data)
    if len(data) != 8:
        raise CodecError(f"an SDO frame has 8 bytes, not {len(data)}")
    command = data[0]
    index, subindex = struct.unpack("<HB", data[1:4])
    if command == 0x80:
        return SdoFrame(SdoKind.ABORT, index, subindex, abort_code=struct.unpack("<I", data[4:8])[0])
    specifier = command >> 5
    expedited, size_given = command & 0x02, command & 0x01
    size = 4 - (command >> 2 & 0x03) if size_given else 4
    value = int.from_bytes(data[4 : 4 + size], "little")
    if from_server:
        if command == 0x60:
            return SdoFrame(SdoKind.DOWNLOAD_ACK, index, subindex)
        if specifier == 2 and expedited:
            return SdoFrame(SdoKind.UPLOAD_REPLY, index, subindex, value, size)
    else:
        if command == 0x40:
            return SdoFrame(SdoKind.UPLOAD_REQUEST, index, subindex)
        if specifier == 1 and expedited:
            return SdoFrame(SdoKind.DOWNLOAD_REQUEST, index, subindex, value, size)
    raise CodecError(f"unsupported SDO command specifier 0x{command:02X} (only expedited transfers)")


# --------------------------------------------------------------------------- EMCY

#: Emergency error codes seen from Elmo drives.
EMCY_CODES: dict[int, str] = {
    0x0000: "error reset or no error",
    0x2340: "short circuit",
    0x3120: "under-voltage",
    0x3310: "over-voltage",
    0x4310: "over-temperature",
    0x6300: "interpreter or RPDO failure",
    0x7121: "motor stuck",
    0x8130: "heartbeat or life-guard error",
    0x8480: "speed tracking error",
    0x8611: "position tracking error",
}


@dataclass(frozen=True)
class Emergency:
    """A decoded EMCY frame.

    Attributes:
        error_code: The CiA 301 emergency error code (0 = error reset).
        error_register: Object 0x1001 at the time of the error.
        elmo_code: Elmo-specific byte (the interpreter EC for code 0x6300).
        data1: First Elmo-specific word.
        data2: Second Elmo-specific word.
    """

    error_code: int
    error_register: int = 0
    elmo_code: int = 0
    data1: int = 0
    data2: int = 0

    @property
    def is_reset(self) -> bool:
        """Whether this frame announces that the error condition is gone."""
        return self.error_code == 0

    @property
    def description(self) -> str:
        """A readable one-line description."""
        meaning = EMCY_CODES.get(self.error_code, "unknown emergency")
        text = f"emergency 0x{self.error_code:04X} ({meaning})"
        if self.error_code == 0x6300 and self.elmo_code:
            text += f", interpreter error {self.elmo_code} ({error_code_meaning(self.elmo_code)})"
        return text


def encode_emcy(emergency: Emergency) -> bytes:
    """Encode an EMCY payload (8 bytes)."""
    try:
        return struct.pack(
            "<HBBHH",
            emergency.error_code,
            emergency.error_register,
            emergency.elmo_code,
            emergency.data1,
            emergency.data2,
        )
    except struct.error as exc:
        raise CodecError(f"emergency field out of range: {emergency}") from exc


def decode_emcy(data: bytes | bytearray) -> Emergency:
    """Decode an EMCY payload.

    Raises:
        CodecError: The payload is not 8 bytes.
    """
    if len(data) != 8:
        raise CodecError(f"an EMCY frame has 8 bytes, not {len(data)}")
    return Emergency(*struct.unpack("<HBBHH", bytes(data)))
