"""IDL types: genom3's JSON mapping in both directions, and the /info descriptions."""

from __future__ import annotations

import enum
import math
from typing import Annotated

import numpy as np
import orjson
import pytest

from aiogenomix.components.core import (
    Boolean, Char, Double, Long, Octet, Short, String, ULong, array, idl_enum, idl_struct, optional, sequence,
    string,
)
from aiogenomix.components.core.runtime import InputError, idl_type


@idl_enum("test::color")
class Color(enum.Enum):
    RED = 0
    GREEN = 1


@idl_struct("test::point")
class Point:
    x: Double = 0.0
    y: Double = 0.0
    tag: Color = Color.RED


def test_integers_refuse_fractions_and_out_of_range() -> None:
    short = idl_type(Short)
    assert short.decode(12, "v") == 12
    assert short.decode(3.0, "v") == 3  # MATLAB sends integral doubles
    with pytest.raises(InputError, match=r"v: expected an integer \(short\), got 1.5"):
        short.decode(1.5, "v")
    with pytest.raises(InputError, match="out of range for short"):
        short.decode(40000, "v")
    with pytest.raises(InputError, match="expected an integer"):
        short.decode("3", "v")
    with pytest.raises(InputError):
        idl_type(ULong).decode(-1, "v")
    assert idl_type(Octet).decode(255, "v") == 255


def test_doubles_take_null_as_nan_and_write_nan_as_null() -> None:
    double = idl_type(Double)
    assert math.isnan(double.decode(None, "v"))
    assert double.encode(math.nan) is None
    assert double.encode(math.inf) is None
    with pytest.raises(InputError, match="expected a number"):
        double.decode("x", "v")
    with pytest.raises(InputError):
        double.decode(True, "v")


def test_booleans_in_both_spellings_out_as_integers() -> None:
    boolean = idl_type(Boolean)
    assert boolean.decode(True, "b") is True and boolean.decode(0, "b") is False
    assert boolean.encode(True) == 1
    with pytest.raises(InputError):
        boolean.decode(2, "b")


def test_strings_and_chars() -> None:
    assert idl_type(String).decode("é", "s") == "é"
    with pytest.raises(InputError, match="bound of 3 bytes"):
        idl_type(string(3)).decode("abcd", "s")
    assert idl_type(Char).decode("a", "c") == "a"
    with pytest.raises(InputError):
        idl_type(Char).decode("ab", "c")


def test_enums_accept_short_and_full_names_and_write_full_names() -> None:
    color = idl_type(Color)
    assert color.decode("GREEN", "c") is Color.GREEN
    assert color.decode("::test::GREEN", "c") is Color.GREEN
    assert color.encode(Color.RED) == "::test::RED"
    with pytest.raises(InputError, match="expected one of ::test::RED, ::test::GREEN"):
        color.decode("BLUE", "c")
    assert color.describe() == {"name": "::test::color", "kind": "enum", "values": ["::test::RED", "::test::GREEN"]}


def test_structs_keep_member_order_and_initial_values() -> None:
    point = idl_type(Point)
    decoded = point.decode({"y": 2, "tag": "GREEN"}, "p")
    assert decoded == Point(x=0.0, y=2.0, tag=Color.GREEN)
    assert orjson.dumps(point.encode(decoded)) == b'{"x":0.0,"y":2.0,"tag":"::test::GREEN"}'
    with pytest.raises(InputError, match=r"p\.z: unknown member 'z' of ::test::point"):
        point.decode({"z": 1}, "p")
    with pytest.raises(InputError, match=r"p\.x: expected a number"):
        point.decode({"x": "no"}, "p")
    assert [m["name"] for m in point.describe()["members"]] == ["x", "y", "tag"]


def test_sequences_arrays_optionals() -> None:
    seq = idl_type(sequence(Long, 3))
    assert seq.decode([1, 2], "s") == [1, 2]
    assert seq.decode({"0": 5, "2": 7}, "s") == [5, 0, 7]  # genom3's sparse index objects
    with pytest.raises(InputError, match="exceed the bound of 3"):
        seq.decode([1, 2, 3, 4], "s")
    with pytest.raises(InputError, match=r"s\[1\]: expected an integer"):
        seq.decode([1, "x"], "s")
    arr = idl_type(array(Double, 3))
    assert arr.decode([1.0], "a") == [1.0, 0.0, 0.0]
    assert arr.describe()["name"] == "double[3]"
    opt = idl_type(optional(Point))
    assert opt.decode(None, "o") is None and opt.encode(None) is None


def test_decoding_at_the_limits_refuses_with_a_readable_message() -> None:
    huge = int("1" * 4000)
    with pytest.raises(InputError, match=r"p: an integer of about 4000 digits is too large for a double"):
        idl_type(Double).decode(huge, "p")
    with pytest.raises(InputError, match=r"an integer of about 4000 digits is out of range for short") as short:
        idl_type(Short).decode(huge, "v")
    assert "1111111111" not in str(short.value)
    for text in ("\ud800", "a\udfffb"):
        with pytest.raises(InputError, match="lone surrogate"):
            idl_type(String).decode(text, "s")
        with pytest.raises(InputError, match="lone surrogate"):
            idl_type(string(128)).decode(text, "s")
    with pytest.raises(InputError, match="one-character"):
        idl_type(Char).decode("\ud800", "c")
    with pytest.raises(InputError, match=r"unknown member '\\udc80' of ::test::point"):
        idl_type(Point).decode({"\udc80": 1}, "p")


def test_index_objects_take_ascii_indices_within_bounds() -> None:
    unbounded, bounded = idl_type(sequence(Long)), idl_type(sequence(Long, 3))
    assert bounded.decode({"2": 5}, "s") == [0, 0, 5]
    for key in ("²", "١", "-1", "1.0"):
        with pytest.raises(InputError, match="expected an array or an index object"):
            unbounded.decode({key: 1}, "s")
    with pytest.raises(InputError, match="beyond the bound of 3"):
        bounded.decode({"3": 1}, "s")
    for key in ("65536", "9" * 5000):  # neither a list of 10**5000 items nor a 500 from int()
        with pytest.raises(InputError, match="beyond the limit of 65536"):
            unbounded.decode({key: 1}, "s")
    assert len(unbounded.decode({"65535": 1}, "s")) == 65536


def test_numpy_sequences_are_not_walked_in_python() -> None:
    samples = idl_type(sequence(Long, numpy=True))
    data = samples.decode([1, -2, 3], "s")
    assert data.dtype == np.dtype("<i4") and data.tolist() == [1, -2, 3]
    big = np.arange(100_000, dtype=np.int32)
    assert samples.encode(big) is big  # handed to orjson as is
    assert orjson.dumps(samples.encode(big[:3]), option=orjson.OPT_SERIALIZE_NUMPY) == b"[0,1,2]"


def test_annotated_docs_do_not_change_the_type() -> None:
    assert idl_type(Annotated[Double, "a doc"]).name == "double"
    assert idl_type(float).name == "double" and idl_type(int).name == "long"
    with pytest.raises(TypeError, match="has no IDL type"):
        idl_type(dict)
