"""Interpolation between measured directions: exact at them, smooth and notch-free between them."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.binaural import HorizontalInterpolator, HrirSet, band_ilds, gcc_phat_itd


@pytest.fixture(scope="module")
def interpolator(kemar: HrirSet) -> HorizontalInterpolator:
    return HorizontalInterpolator(kemar)


def test_at_a_measured_direction_it_is_the_measurement(kemar: HrirSet, interpolator: HorizontalInterpolator) -> None:
    for azimuth in (-180.0, -90.0, 0.0, 35.0, 175.0):
        assert np.array_equal(interpolator.at(azimuth)[0], kemar.taps[kemar.index(azimuth)])


def test_azimuths_wrap_round_the_circle(interpolator: HorizontalInterpolator) -> None:
    assert np.array_equal(interpolator.at(362.5), interpolator.at(2.5))
    assert np.array_equal(interpolator.at(-177.5), interpolator.at(182.5))


def test_a_left_out_direction_is_predicted_from_its_neighbours_10_degrees_apart(kemar: HrirSet) -> None:
    horizontal = kemar.horizontal()
    every_other = HrirSet(kemar.rate, horizontal.azimuth[::2].copy(), horizontal.elevation[::2].copy(),
                          horizontal.taps[::2].copy())
    predicted = HorizontalInterpolator(every_other).at(horizontal.azimuth[1::2])
    measured = horizontal.taps[1::2]
    # In front and behind (away from the interaural axis, where KEMAR's own GCC-PHAT ITD jumps).
    for index, azimuth in enumerate(horizontal.azimuth[1::2]):
        if abs(abs(azimuth) - 90.0) < 40.0:
            continue
        itd = gcc_phat_itd(*predicted[index].T, max_lag=50) - gcc_phat_itd(*measured[index].T, max_lag=50)
        ild = band_ilds(*predicted[index].T, kemar.rate) - band_ilds(*measured[index].T, kemar.rate)
        assert abs(itd) < 0.5, azimuth
        assert np.sqrt(np.mean(ild**2)) < 1.5, azimuth


def test_the_itd_moves_steadily_between_measured_directions(interpolator: HorizontalInterpolator) -> None:
    itds = [gcc_phat_itd(*taps.T, max_lag=50) for taps in interpolator.at(np.arange(0.0, 30.5, 0.5))]
    assert np.all(np.diff(itds) > -0.05)
    assert itds[0] == pytest.approx(0.0, abs=0.1)
