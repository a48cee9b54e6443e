"""The sans-I/O codec against the frame examples of the Elmo DS 301 guide, and round trips."""

from __future__ import annotations

import pytest

from aiogenomix.components.kemar import CodecError
from aiogenomix.components.kemar._codec import (
    CobIds, CommandKind, Emergency, InterpreterReply, InterpreterRequest, MotorFault, NmtCommand,
    SdoKind, StatusRegister, decode_emcy, decode_nmt, decode_reply, decode_sdo, describe_motor_fault, encode_emcy,
    encode_execute, encode_nmt, encode_query, encode_sdo_abort, encode_sdo_download, encode_sdo_download_ack,
    encode_sdo_upload_reply, encode_sdo_upload_request, encode_set, error_code_meaning,
)


def frame(text: str) -> bytes:
    return bytes.fromhex(text)


# --------------------------------------------------------------------------- the guide's examples

def test_set_integer_example() -> None:
    assert encode_set("AC", 150000) == frame("41 43 00 00 F0 49 02 00")


def test_query_example_is_the_bare_header() -> None:
    assert encode_query("AC") == frame("41 43 00 00")


def test_set_float_with_index_example() -> None:
    assert encode_set("CL", 1.0, index=1) == frame("43 4C 01 80 00 00 80 3F")


def test_error_reply_example() -> None:
    reply = decode_reply(frame("43 41 01 40 15 00 00 00"))
    assert (reply.mnemonic, reply.index, reply.error_code, reply.value) == ("CA", 1, 21, None)
    assert reply.is_error
    assert error_code_meaning(21) == "operand out of range"


def test_begin_motion_failure_example() -> None:
    reply = decode_reply(frame("42 47 00 40 3A 00 00 00"))
    assert (reply.mnemonic, reply.error_code) == ("BG", 58)
    assert error_code_meaning(58) == "motor must be on"


def test_begin_motion_success_is_header_and_zeros() -> None:
    reply = decode_reply(frame("42 47 00 00 00 00 00 00"))
    assert reply == InterpreterReply("BG", 0, 0)
    assert not reply.is_error


# --------------------------------------------------------------------------- requests and replies

def test_long_query_sets_the_query_flag() -> None:
    assert encode_query("PX", long_query=True) == frame("50 58 00 40 00 00 00 00")
    assert InterpreterRequest.decode(frame("50 58 00 40 00 00 00 00")).kind is CommandKind.QUERY


def test_execute_is_dlc4_and_decodes_as_execute() -> None:
    assert encode_execute("BG") == b"BG\x00\x00"
    assert InterpreterRequest.decode(b"BG\x00\x00").kind is CommandKind.EXECUTE
    assert InterpreterRequest.decode(b"PX\x00\x00").kind is CommandKind.QUERY


@pytest.mark.parametrize("value", [0, 1, -1, 2**31 - 1, -(2**31), 123456, -20480])
def test_integer_set_round_trips(value: int) -> None:
    request = InterpreterRequest.decode(encode_set("PA", value))
    assert request == InterpreterRequest(CommandKind.SET, "PA", 0, value)


def test_unsigned_spelling_of_a_mask_is_accepted() -> None:
    assert encode_set("MI", 0xFFFFFFFF)[4:] == b"\xff\xff\xff\xff"


def test_large_index_uses_the_high_bits_of_byte_3() -> None:
    data = encode_set("XX", 7, index=0x1234)
    assert data[2] == 0x34 and data[3] & 0x3F == 0x12
    assert InterpreterRequest.decode(data).index == 0x1234


def test_reply_round_trips_floats_and_errors() -> None:
    for reply in (InterpreterReply("IQ", 0, 1.5), InterpreterReply("HM", 3, 7), InterpreterReply("UM", 0, None, 57)):
        assert InterpreterReply.decode(reply.encode()) == reply


def test_mnemonic_is_upper_cased() -> None:
    assert encode_query("px") == b"PX\x00\x00"


@pytest.mark.parametrize("bad", [lambda: encode_set("P", 1), lambda: encode_set("P1", 1),
                                 lambda: encode_set("PA", 2**32), lambda: encode_set("PA", float("nan")),
                                 lambda: encode_set("PA", 1, index=1 << 14), lambda: decode_reply(b"PX\x00\x00"),
                                 lambda: InterpreterRequest.decode(b"PX\x00")])
def test_bad_frames_raise_codec_error(bad) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(CodecError):
        bad()


# --------------------------------------------------------------------------- CANopen frames

def test_cob_ids_of_the_kemar_node() -> None:
    cob = CobIds(0x7F)
    assert (cob.interpreter_request, cob.interpreter_reply) == (0x37F, 0x2FF)
    assert (cob.emcy, cob.sdo_request, cob.sdo_reply, cob.heartbeat) == (0xFF, 0x67F, 0x5FF, 0x77F)
    with pytest.raises(CodecError):
        CobIds(0)


def test_nmt_start() -> None:
    assert encode_nmt(NmtCommand.START, 0x7F) == b"\x01\x7f"
    assert decode_nmt(b"\x82\x00") == (NmtCommand.RESET_COMMUNICATION, 0)
    with pytest.raises(CodecError):
        decode_nmt(b"\x05\x7f")


@pytest.mark.parametrize(("size", "command"), [(4, 0x23), (3, 0x27), (2, 0x2B), (1, 0x2F)])
def test_sdo_download_command_specifiers(size: int, command: int) -> None:
    data = encode_sdo_download(0x1800, 2, 1, size)
    assert data[:4] == bytes((command, 0x00, 0x18, 0x02))
    decoded = decode_sdo(data, from_server=False)
    assert (decoded.kind, decoded.index, decoded.subindex, decoded.value, decoded.size) == (
        SdoKind.DOWNLOAD_REQUEST, 0x1800, 2, 1, size)


def test_sdo_upload_and_replies() -> None:
    assert encode_sdo_upload_request(0x1A00, 1) == frame("40 00 1A 01 00 00 00 00")
    assert encode_sdo_download_ack(0x1016, 1) == frame("60 16 10 01 00 00 00 00")
    reply = decode_sdo(encode_sdo_upload_reply(0x1A00, 1, 0x60640020), from_server=True)
    assert (reply.kind, reply.value) == (SdoKind.UPLOAD_REPLY, 0x60640020)
    short = decode_sdo(encode_sdo_upload_reply(0x1800, 2, 1, size=1), from_server=True)
    assert (short.value, short.size) == (1, 1)
    assert decode_sdo(encode_sdo_download_ack(0x1016, 1), from_server=True).kind is SdoKind.DOWNLOAD_ACK


def test_sdo_abort() -> None:
    data = encode_sdo_abort(0x1234, 0, 0x06020000)
    assert data == frame("80 34 12 00 00 00 02 06")
    assert decode_sdo(data, from_server=True).abort_code == 0x06020000


def test_segmented_sdo_is_refused() -> None:
    with pytest.raises(CodecError):
        decode_sdo(frame("41 00 10 00 10 00 00 00"), from_server=True)


def test_emcy_round_trip_and_description() -> None:
    emergency = Emergency(0x7121, 0x01, 0, 0, 0)
    data = encode_emcy(emergency)
    assert data == frame("21 71 01 00 00 00 00 00")
    assert decode_emcy(data) == emergency
    assert "motor stuck" in emergency.description
    interpreter = decode_emcy(frame("00 63 01 3A 00 00 00 00"))
    assert "motor must be on" in interpreter.description
    assert Emergency(0).is_reset


# --------------------------------------------------------------------------- SR and MF

def test_status_register_fields() -> None:
    sr = StatusRegister.compose(motor_on=True, unit_mode=5, motion_status=2, stopped_by_limit=True, homing=True)
    assert sr.motor_on and sr.unit_mode == 5 and sr.motion_status == 2 and sr.stopped_by_limit and sr.homing
    assert sr.raw == (1 << 4) | (5 << 7) | (1 << 11) | (2 << 14) | (1 << 28)
    assert sr.describe() == "motor on, UM=5, moving, homing armed, stopped by a limit"


def test_status_register_problem_details() -> None:
    sr = StatusRegister(0b1001 | 1 << 6)  # bit 0 + code 4 in bits 1-3 ... plus a latched fault
    assert sr.drive_problem and sr.motor_fault
    assert "motor fault latched" in sr.describe()
    assert "under-voltage" in StatusRegister.compose(servo_status=1).describe()


def test_status_register_accepts_negative_int32() -> None:
    assert StatusRegister(-1).cpu_fault


def test_motor_fault_text() -> None:
    assert describe_motor_fault(0) == "no fault"
    assert describe_motor_fault(MotorFault.MOTOR_STUCK) == "motor stuck"
    text = describe_motor_fault(MotorFault.POSITION_TRACKING | MotorFault.SERVO_DRIVE_FAULT | 2 << 13)
    assert text == "position tracking error, servo drive fault: over-voltage"
    assert "other bits" in describe_motor_fault(0x2)
