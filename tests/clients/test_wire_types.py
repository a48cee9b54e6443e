"""Encoding and decoding of genom JSON by IDL type, without a gateway."""

from __future__ import annotations

import enum
import json
import math

import numpy as np
import pytest
from aiogenomix.clients import Record
from aiogenomix.clients._types import annotation_source, decode, encode, zero
from aiogenomix.clients._wire import base_url, parse_status

DOUBLE = {"name": "double", "kind": "double"}
SHORT = {"name": "short", "kind": "short"}
ULONG = {"name": "unsigned long", "kind": "unsigned long"}
BOOL = {"name": "boolean", "kind": "boolean"}
SPEED = {"name": "::demo::speed", "kind": "enum", "values": ["::demo::SLOW", "::demo::MEDIUM", "::demo::FAST"]}
STATE = {"name": "::demo::state", "kind": "struct",
         "members": [{"name": "position", "type": DOUBLE}, {"name": "speed", "type": DOUBLE}]}
SAMPLES = {"name": "sequence<long>", "kind": "sequence", "bound": 4,
           "element": {"name": "long", "kind": "long"}}
MATRIX = {"name": "sequence<sequence<float>>", "kind": "sequence", "bound": None,
          "element": {"name": "sequence<float>", "kind": "sequence", "bound": None,
                      "element": {"name": "float", "kind": "float"}}}
TRIPLE = {"name": "double[3]", "kind": "array", "length": 3, "element": DOUBLE}


class Speed(enum.Enum):
    SLOW = 0
    FAST = 2


def test_integers_are_never_sent_as_floats() -> None:
    for value in (1, 1.0, np.int64(1), np.float32(1.0), True):
        encoded = encode(value, SHORT)
        assert encoded == 1 and type(encoded) is int
        assert json.dumps(encoded) == "1"
    with pytest.raises(TypeError, match="integer"):
        encode(1.5, SHORT)
    with pytest.raises(ValueError, match="out of range"):
        encode(70000, SHORT)
    with pytest.raises(ValueError, match="out of range"):
        encode(-1, ULONG)
    with pytest.raises(TypeError):
        encode("1", SHORT)


def test_doubles_booleans_and_nan() -> None:
    assert encode(1, DOUBLE) == 1.0 and type(encode(np.float32(0.5), DOUBLE)) is float
    assert encode(math.nan, DOUBLE) is None
    assert math.isnan(decode(None, DOUBLE))
    assert encode(True, BOOL) == 1 and encode(np.bool_(False), BOOL) == 0 and encode(1, BOOL) == 1
    assert decode(1, BOOL) is True
    with pytest.raises(TypeError):
        encode(True, DOUBLE)
    with pytest.raises(TypeError):
        encode(2, BOOL)


def test_enums_by_short_or_full_name() -> None:
    assert encode("SLOW", SPEED) == "::demo::SLOW"
    assert encode("::demo::FAST", SPEED) == "::demo::FAST"
    assert encode(Speed.FAST, SPEED) == "::demo::FAST"
    with pytest.raises(ValueError, match="SLOW, MEDIUM, FAST"):
        encode("VERY_FAST", SPEED)


def test_structs() -> None:
    assert encode({"speed": 1}, STATE) == {"speed": 1.0}
    with pytest.raises(ValueError, match="no member 'pos'"):
        encode({"pos": 1}, STATE)
    with pytest.raises(TypeError, match=r"state\.speed"):
        encode({"speed": "x"}, STATE, "state")
    record = decode({"position": 1, "speed": None}, STATE)
    assert isinstance(record, Record) and record.position == 1.0 and math.isnan(record.speed)
    assert list(record) == ["position", "speed"]
    with pytest.raises(AttributeError, match="members: position, speed"):
        record.nope  # noqa: B018


def test_sequences_and_numpy() -> None:
    assert encode(np.array([1, 2, 3], dtype=np.int32), SAMPLES) == [1, 2, 3]
    assert encode(np.array([1.0, 2.0]), SAMPLES) == [1, 2]
    assert all(type(v) is int for v in encode(np.array([1.0, 2.0]), SAMPLES))
    assert encode((1, 2), SAMPLES) == [1, 2]
    assert encode({"3": 7}, SAMPLES) == {"3": 7}
    with pytest.raises(ValueError, match="at most 4"):
        encode([1] * 5, SAMPLES)
    with pytest.raises(TypeError):
        encode(np.array([1.5]), SAMPLES)
    with pytest.raises(TypeError):
        encode("abc", SAMPLES)
    assert encode(np.array([1.0, np.nan, 2.0]), TRIPLE) == [1.0, None, 2.0]

    samples = decode([1, 2, 3], SAMPLES)
    assert isinstance(samples, np.ndarray) and samples.dtype == np.int32
    matrix = decode([[1, 2], [3, None]], MATRIX)
    assert matrix.shape == (2, 2) and matrix.dtype == np.float32 and math.isnan(matrix[1, 1])
    ragged = decode([[1], [2, 3]], MATRIX)
    assert isinstance(ragged, list) and [a.tolist() for a in ragged] == [[1.0], [2.0, 3.0]]


def test_zero_and_annotations() -> None:
    assert zero(STATE) == {"position": 0.0, "speed": 0.0}
    assert zero(SPEED) == "::demo::SLOW"
    assert zero(TRIPLE).tolist() == [0.0, 0.0, 0.0]
    assert annotation_source(SAMPLES, "in") == "numpy.ndarray | Sequence[int]"
    assert annotation_source(SAMPLES, "out") == "numpy.ndarray"
    assert annotation_source(STATE, "out") == "Record"
    assert "'SLOW'" in annotation_source(SPEED, "in") and "'SLOW'" not in annotation_source(SPEED, "out")


def test_addresses_and_status_objects() -> None:
    assert base_url(None) == "http://localhost:8080"
    assert base_url("robot:9000") == "http://robot:9000"
    assert base_url("robot") == "http://robot:8080"
    assert base_url("http://127.0.0.1:5/") == "http://127.0.0.1:5"
    with pytest.raises(ValueError):
        base_url("ftp://robot")
    assert parse_status({"id": "demo::0", "status": "sent"})["status"] == "sent"
    from aiogenomix.clients import ProtocolError
    for bad in ({"status": "sent"}, {"id": "demo::0", "status": "running"}, {"id": "d::0", "status": "error"}, 3):
        with pytest.raises(ProtocolError):
            parse_status(bad)
