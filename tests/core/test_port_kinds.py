"""A type says what its data is (its port kind), once: checked where declared, given in /info, read by any tool."""

from __future__ import annotations

import dataclasses
import math
from typing import Annotated, Any, ClassVar

import numpy as np
import pytest
from numpy.typing import NDArray

from aiogenomix.components.core import (
    AudioStream, DescribedType, Double, HeadState, Long, MemberNeed, PortKind, String, ULong, Unit, carried_by,
    idl_struct,
)
from aiogenomix.components.core.runtime import idl_type


@idl_struct("kinds::head", carries=HeadState(position="azimuth", velocity="turning"))
class Head:
    azimuth: Annotated[Double, Unit("deg")] = 0.0
    turning: Annotated[Double, Unit("deg/s")] = 0.0


@idl_struct("kinds::time")
class Time:
    tv_sec: Long = 0
    tv_nsec: Long = 0


@idl_struct("kinds::ears", carries=AudioStream(numbering="chunks", index="last", rate="rate", start="began",
                                               channels=("left", "right"), head_azimuth="heads"))
class Ears:
    rate: ULong = 0
    last: ULong = 0
    began: Time = dataclasses.field(default_factory=Time)
    left: NDArray[np.int16] = dataclasses.field(default_factory=lambda: np.zeros(0, np.int16))
    right: NDArray[np.int16] = dataclasses.field(default_factory=lambda: np.zeros(0, np.int16))
    heads: Annotated[NDArray[np.float64], Unit("rad")] = dataclasses.field(default_factory=lambda: np.zeros(0))


def test_the_kind_is_in_the_types_description_and_read_back_from_it() -> None:
    described = idl_type(Head).describe()
    assert described["carries"] == {"kind": "head_state", "position": "azimuth", "velocity": "turning"}
    kind = carried_by(described)
    assert isinstance(kind, HeadState)
    # Read by the units the members declare: degrees to radians.
    assert kind.read({"azimuth": 90.0, "turning": None}).position == pytest.approx(math.pi / 2)
    assert math.isnan(kind.read({"azimuth": 90.0, "turning": None}).velocity)
    # A port known only by its description (another process's, a recorded one) carries the same kind.
    assert DescribedType(described, "mirrored").carries == kind


def test_a_kind_that_does_not_fit_its_struct_is_refused_where_it_is_declared() -> None:
    with pytest.raises(TypeError, match="has no number member 'yaw'"):
        @idl_struct("kinds::bad", carries=HeadState(position="yaw"))
        class Bad:
            azimuth: Double = 0.0
    with pytest.raises(TypeError, match="azimuth is in m, not an angle"):
        @idl_struct("kinds::metres", carries=HeadState(position="azimuth"))
        class Metres:
            azimuth: Annotated[Double, Unit("m")] = 0.0
    with pytest.raises(TypeError, match="no member 'mono' holding a sequence"):
        @idl_struct("kinds::text", carries=AudioStream(numbering="frames", index="n", rate="n", channels=("mono",)))
        class Text:
            n: ULong = 0
            mono: String = ""
    with pytest.raises(ValueError, match="numbering is chunks or frames"):
        AudioStream(numbering="samples", index="n", rate="r")


def test_a_kind_unknown_here_or_malformed_is_plain_data() -> None:
    described = idl_type(Head).describe()
    assert carried_by({**described, "carries": {"kind": "hologram", "beam": "azimuth"}}) is None
    assert carried_by({**described, "carries": {"kind": "head_state", "position": 3}}) is None
    assert carried_by({**described, "carries": {"kind": "head_state", "position": "nowhere"}}) is None
    assert carried_by({**described, "carries": "head_state"}) is None
    # What a newer version adds to a kind is left aside.
    assert isinstance(carried_by({**described, "carries": {**described["carries"], "tilt": "x"}}), HeadState)


def test_another_packages_kind_is_known_by_its_name() -> None:
    @dataclasses.dataclass(frozen=True, kw_only=True)
    class Thermometer(PortKind, kind="test_temperature"):
        celsius: str = "celsius"
        needs: ClassVar[dict[str, MemberNeed]] = {"celsius": MemberNeed("number")}

    @idl_struct("kinds::weather", carries=Thermometer())
    class Weather:
        celsius: Double = 0.0

    assert carried_by(idl_type(Weather).describe()) == Thermometer()
    assert PortKind.known()["test_temperature"] is Thermometer


def chunks_of(first: int, last: int, size: int = 4) -> dict[str, Any]:
    """Chunks *first*..*last* of 16-bit samples saying their frame number, each with the head at chunk / 10 rad."""
    frames = np.arange((first - 1) * size + 1, last * size + 1, dtype=np.int16)
    return {"rate": 100, "last": last, "began": {"tv_sec": 1000, "tv_nsec": 0}, "left": frames, "right": -frames,
            "heads": np.arange(first, last + 1) / 10}


def test_an_audio_read_of_chunks_says_its_frames_their_times_and_the_head() -> None:
    kind = idl_type(Ears).carries
    assert isinstance(kind, AudioStream) and kind.describe()["sample"] == "int16"
    read = kind.read(chunks_of(3, 5), since=2, now=0.0)
    # 16-bit samples left-justified into 32 bits: one scale for every port.
    np.testing.assert_array_equal(read.frames[:, 0] >> 16, np.arange(9, 21))
    np.testing.assert_array_equal(read.frames[:, 1] >> 16, -np.arange(9, 21))
    assert [(p.chunk, p.first_frame, p.offset, p.frames) for p in read.pieces] == [(3, 9, 0, 4), (4, 13, 4, 4),
                                                                                   (5, 17, 8, 4)]
    assert [p.stamp for p in read.pieces] == pytest.approx([1000.08, 1000.12, 1000.16])
    np.testing.assert_allclose(read.head_azimuths(), np.degrees([0.3, 0.4, 0.5]))
    assert (read.first_frame, read.lost_frames, read.chunk_frames, read.newest) == (9, 0, 4, 5)


def test_an_audio_read_leaves_out_what_the_reader_has_and_counts_what_it_missed() -> None:
    kind = idl_type(Ears).carries
    assert isinstance(kind, AudioStream)
    again = kind.read(chunks_of(3, 6), since=4, now=0.0)        # chunks 3 and 4 read before
    assert [p.chunk for p in again.pieces] == [5, 6] and again.lost_frames == 0
    np.testing.assert_array_equal(again.frames[:, 0] >> 16, np.arange(17, 25))
    late = kind.read(chunks_of(8, 9), since=5, lost=2, now=0.0)  # 6 and 7 gone from the window
    assert [p.chunk for p in late.pieces] == [8, 9] and late.lost_frames == 8
    with pytest.raises(ValueError, match="holds 7 frames, not 2 whole chunks"):
        cut = chunks_of(1, 2)
        del cut["heads"]
        cut["left"], cut["right"] = cut["left"][:-1], cut["right"][:-1]
        kind.read(cut, since=0, now=0.0)


def test_audio_numbered_by_frame_is_cut_at_its_chunks_and_timed_back_from_the_read() -> None:
    kind = AudioStream(numbering="frames", index="last", rate="rate", chunk_frames="size", interleaved=2,
                       channels=("samples",))
    described = {"name": "::x", "kind": "struct", "members": [
        {"name": n, "type": {"name": "unsigned long", "kind": "unsigned long"}} for n in ("last", "rate", "size")] + [
        {"name": "samples", "type": {"name": "sequence<float>", "kind": "sequence", "bound": None,
                                     "element": {"name": "float", "kind": "float"}}}]}
    bound = kind.bind(described)
    # Frames 6..12 of chunks of 5, interleaved floats (full scale 1), read at t = 50 s at 10 Hz.
    samples = np.stack([np.full(7, 0.5), np.full(7, -0.25)], axis=1).reshape(-1).astype(np.float32)
    read = bound.read({"last": 12, "rate": 10, "size": 5, "samples": samples}, since=5, now=50.0)
    assert [(p.chunk, p.first_frame, p.frames) for p in read.pieces] == [(2, 6, 5), (3, 11, 2)]
    assert [p.stamp for p in read.pieces] == pytest.approx([50.0 - 0.7, 50.0 - 0.2])
    np.testing.assert_array_equal(read.frames[0], [2**30, -(2**29)])
    assert read.channels == 2 and all(math.isnan(p.head_azimuth) for p in read.pieces)
