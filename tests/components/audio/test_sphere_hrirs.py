"""The spherical head as HRIRs (``audio.sphere_hrirs``): the renderer's sphere, a head any HRIR user takes."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pytest

from aiogenomix.components.audio import sphere_hrirs, woodworth_itd
from aiogenomix.components.binaural import HrirSet, Pose, Talker, gcc_phat_itd, render_scene

RATE = 44_100.0


@pytest.fixture(scope="module")
def sphere() -> HrirSet:
    return sphere_hrirs(rate=RATE)


def _at(hrirs: HrirSet, azimuth: float, elevation: float = 0.0) -> npt.NDArray[np.float64]:
    index = np.flatnonzero((hrirs.azimuth == azimuth) & (hrirs.elevation == elevation))
    assert len(index) == 1
    return np.asarray(hrirs.taps[index[0]])


@pytest.mark.parametrize("azimuth", [-90.0, -30.0, 0.0, 45.0, 80.0])
def test_its_interaural_delay_is_woodworths(sphere: HrirSet, azimuth: float) -> None:
    taps = _at(sphere, azimuth)
    itd = gcc_phat_itd(taps[:, 0], taps[:, 1], max_lag=64) / RATE
    assert itd == pytest.approx(woodworth_itd(azimuth), abs=1.5 / RATE)
    # The far ear is the quieter (the head's shadow), the ears alike straight ahead.
    left, right = (float(np.sum(taps[:, ear] ** 2)) for ear in (0, 1))
    assert (left > right) if azimuth > 0 else (left < right) if azimuth < 0 else left == pytest.approx(right)


def test_front_and_back_are_alike_and_the_set_covers_the_kemar_rings(sphere: HrirSet) -> None:
    np.testing.assert_allclose(_at(sphere, 30.0), _at(sphere, 150.0), atol=1e-12)
    np.testing.assert_allclose(_at(sphere, -60.0, 20.0), _at(sphere, -120.0, 20.0), atol=1e-12)
    assert sphere.rate == RATE and sphere.taps.shape[1:] == (512, 2) and "spherical head" in sphere.source
    assert set(np.unique(sphere.elevation)) == set(np.arange(-40.0, 91.0, 10.0))


def test_a_scene_renders_through_it(sphere: HrirSet) -> None:
    listener = Pose(2.0, 2.0)
    noise = np.random.default_rng(3).standard_normal(round(0.3 * RATE)) * 0.1
    talker = Talker(noise, listener.at(90.0, distance=1.5))
    ears = render_scene([talker], listener, rate=RATE, seconds=0.3, hrirs=sphere)
    itd = gcc_phat_itd(ears[:, 0], ears[:, 1], max_lag=64) / RATE
    assert itd == pytest.approx(woodworth_itd(90.0), abs=1.5 / RATE)      # straight to the left
