"""Other heads: SOFA files written and read back (ours and another library's), refusals, and the snowman head."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.binaural import (
    HrirSet, Pose, SofaError, Talker, band_ilds, gcc_phat_itd, read_sofa, render_scene, snowman_hrirs, write_sofa,
)


def test_the_mit_set_written_to_sofa_reads_back_the_same(tmp_path, kemar: HrirSet) -> None:
    path = tmp_path / "kemar.sofa"
    write_sofa(kemar, path)
    again = read_sofa(path)
    assert again.rate == kemar.rate
    assert np.array_equal(again.taps, kemar.taps)
    assert np.allclose(again.azimuth, kemar.azimuth) and np.allclose(again.elevation, kemar.elevation)
    assert "SOFA" in again.source


def test_an_aes69_verifier_accepts_our_file_and_we_read_its_own(tmp_path, kemar: HrirSet) -> None:
    sofar = pytest.importorskip("sofar")
    ours = tmp_path / "ours.sofa"
    write_sofa(kemar, ours)
    checked = sofar.read_sofa(str(ours), verify=True, verbose=False)
    assert checked.GLOBAL_SOFAConventions == "SimpleFreeFieldHRIR"
    assert np.array_equal(np.asarray(checked.Data_IR), kemar.taps.transpose(0, 2, 1))
    # sofar's own file of the same data, with the right ear first and Cartesian positions, reads the same.
    theirs = sofar.Sofa("SimpleFreeFieldHRIR")
    theirs.Data_IR = kemar.taps.transpose(0, 2, 1)[:, ::-1]
    theirs.ReceiverPosition = np.array([[0.0, -0.09, 0.0], [0.0, 0.09, 0.0]])
    a, e = np.radians(kemar.azimuth), np.radians(kemar.elevation)
    theirs.SourcePosition = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=1) * 1.4
    theirs.SourcePosition_Type, theirs.SourcePosition_Units = "cartesian", "metre"
    theirs.Data_SamplingRate = 44_100.0
    sofar.write_sofa(str(tmp_path / "theirs.sofa"), theirs)
    read = read_sofa(tmp_path / "theirs.sofa")
    assert np.array_equal(read.taps, kemar.taps)
    assert np.allclose(read.azimuth, kemar.azimuth, atol=1e-9) and np.allclose(read.elevation, kemar.elevation)


def test_a_file_that_is_not_a_head_is_refused_at_load_saying_why(tmp_path, kemar: HrirSet) -> None:
    garbage = tmp_path / "garbage.sofa"
    garbage.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(200))
    with pytest.raises(SofaError, match="not a SOFA file"):
        read_sofa(garbage)
    # A measured room's convention.
    import netCDF4

    write_sofa(kemar, tmp_path / "room.sofa")
    with netCDF4.Dataset(tmp_path / "room.sofa", "a") as data:
        data.SOFAConventions = "SingleRoomMIMOSRIR"
    with pytest.raises(SofaError, match="SingleRoomMIMOSRIR.*measured room"):
        read_sofa(tmp_path / "room.sofa")
    # A head file without its impulse responses.
    with netCDF4.Dataset(tmp_path / "empty.sofa", "w") as data:
        data.Conventions, data.SOFAConventions = "SOFA", "SimpleFreeFieldHRIR"
    with pytest.raises(SofaError, match="no Data.IR"):
        read_sofa(tmp_path / "empty.sofa")
    # A head file whose measurements and positions disagree.
    write_sofa(kemar, tmp_path / "head.sofa")
    with netCDF4.Dataset(tmp_path / "head.sofa", "a") as data:
        data.variables["Data.SamplingRate"][:] = [np.nan]
    with pytest.raises(SofaError, match="Data.SamplingRate"):
        read_sofa(tmp_path / "head.sofa")


def test_the_snowman_is_another_head_than_the_kemar(kemar: HrirSet) -> None:
    snowman = snowman_hrirs()
    assert snowman.rate == 44_100.0 and snowman.length == 512
    assert len(snowman.horizontal()) == 72
    for azimuth in (30.0, 90.0, 150.0):
        left, right = snowman.taps[snowman.index(azimuth)].T
        mirrored = snowman.taps[snowman.index(-azimuth)]
        # Left-right symmetric, the near ear first and louder.
        assert gcc_phat_itd(left, right, max_lag=50) > 5
        assert np.allclose(mirrored[:, ::-1], np.stack([left, right], axis=1), atol=1e-9)
        assert np.sum(left**2) > 2 * np.sum(right**2)
    # A smaller head without pinnae: its ITD at 90° is shorter than the KEMAR's by over 3 samples
    # (27 against 32), and its spectral cues are not the KEMAR's.
    itd = gcc_phat_itd(*snowman.taps[snowman.index(90.0)].T, max_lag=50)
    assert itd < gcc_phat_itd(*kemar.taps[kemar.index(90.0)].T, max_lag=50) - 3
    ours = band_ilds(*snowman.taps[snowman.index(60.0)].T, 44_100.0)
    theirs = band_ilds(*kemar.taps[kemar.index(60.0)].T, 44_100.0)
    assert np.sqrt(np.mean((ours - theirs) ** 2)) > 2.0
    # Ears behind the axis and a torso: front and back differ.
    front = gcc_phat_itd(*snowman.taps[snowman.index(30.0)].T, max_lag=50)
    back = gcc_phat_itd(*snowman.taps[snowman.index(150.0)].T, max_lag=50)
    assert abs(front - back) > 0.5


def test_a_scene_renders_through_any_head(tmp_path) -> None:
    write_sofa(snowman_hrirs(), tmp_path / "snowman.sofa")
    head = read_sofa(tmp_path / "snowman.sofa").resampled(24_414.0)
    noise = np.random.default_rng(2).standard_normal(24_414)
    listener = Pose(0.0, 0.0, 1.5)
    ears = render_scene([Talker(noise, listener.at(90.0, distance=1.0))], listener, rate=24_414.0, seconds=1.0,
                        hrirs=head)[2048:]
    measured = head.taps[head.index(90.0)]
    assert gcc_phat_itd(*ears.T, max_lag=30) == pytest.approx(gcc_phat_itd(*measured.T, max_lag=30), abs=1.0)
