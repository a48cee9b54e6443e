"""The measured KEMAR set: its shape, conventions and check figure, the cache, and resampling."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from aiogenomix.components.binaural import HrirError, HrirSet, band_ilds, gcc_phat_itd, kemar_cache_path, load_kemar


def test_the_set_has_710_directions_of_512_taps_at_44_1_khz(kemar: HrirSet) -> None:
    assert len(kemar) == 710 and kemar.length == 512 and kemar.rate == 44_100.0
    assert kemar.taps.shape == (710, 512, 2)
    horizontal = kemar.horizontal()
    assert np.array_equal(horizontal.azimuth, np.arange(-180.0, 180.0, 5.0))


def test_at_90_degrees_the_left_ear_leads_by_32_samples_with_11_8_db_more_energy(kemar: HrirSet) -> None:
    left, right = kemar.taps[kemar.index(90.0)].T
    assert round(gcc_phat_itd(left, right, max_lag=50)) == 32
    assert 10 * np.log10(np.sum(left**2) / np.sum(right**2)) == pytest.approx(11.8, abs=0.05)
    # And the mirror image on the right.
    left, right = kemar.taps[kemar.index(-90.0)].T
    assert round(gcc_phat_itd(left, right, max_lag=50)) == -32


def test_the_cache_holds_the_same_responses_and_is_read_without_slab(tmp_path, kemar: HrirSet) -> None:
    converted = load_kemar(tmp_path)
    path = kemar_cache_path(tmp_path)
    assert path.is_file() and path.stat().st_size < 2_000_000
    with np.load(path) as saved:
        assert np.array_equal(saved["taps"].astype(np.float64), kemar.taps)
    assert np.array_equal(converted.taps, kemar.taps) and np.array_equal(converted.azimuth, kemar.azimuth)
    # Another process reads the cache and never imports slab (seconds, and it edits sys.path).
    code = ("import sys; from aiogenomix.components.binaural import load_kemar; "
            f"assert len(load_kemar({str(tmp_path)!r})) == 710; print('slab' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout == "False\n"


def test_a_damaged_cache_is_converted_again(tmp_path) -> None:
    path = kemar_cache_path(tmp_path)
    path.write_bytes(b"not an npz")
    load_kemar(tmp_path)
    with np.load(path) as saved:
        assert saved["taps"].shape == (710, 512, 2)


def test_sets_are_read_only(kemar: HrirSet) -> None:
    with pytest.raises(ValueError):
        kemar.taps[0, 0, 0] = 1.0


@pytest.mark.parametrize("rate", [24_414.0, 48_000.0, 16_000.0])
def test_resampled_responses_keep_their_delays_and_levels(kemar: HrirSet, rate: float) -> None:
    resampled = kemar.resampled(rate)
    assert resampled.rate == rate
    assert resampled.length == pytest.approx(512 * rate / 44_100, abs=1)
    for azimuth in (30.0, 90.0, 150.0):
        original = kemar.taps[kemar.index(azimuth)]
        again = resampled.taps[resampled.index(azimuth)]
        itd = gcc_phat_itd(*original.T, max_lag=50) / 44_100
        assert gcc_phat_itd(*again.T, max_lag=50) / rate == pytest.approx(itd, abs=1.0 / rate)
        centres = [500.0, 1000.0, 2000.0, 4000.0]
        assert band_ilds(*again.T, rate, centres) == pytest.approx(band_ilds(*original.T, 44_100, centres), abs=0.3)


def test_the_summer_school_rate_is_exact_and_cached(kemar: HrirSet) -> None:
    assert kemar.resampled(24_414) is kemar.resampled(24_414.0)
    assert kemar.resampled(44_100.0) is kemar


def test_a_malformed_set_is_refused() -> None:
    with pytest.raises(HrirError, match="taps"):
        HrirSet(44_100.0, np.zeros(3), np.zeros(3), np.zeros((3, 8, 1)))
    with pytest.raises(HrirError, match="rate"):
        HrirSet(0.0, np.zeros(1), np.zeros(1), np.zeros((1, 8, 2)))
