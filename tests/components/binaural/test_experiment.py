"""The localisation experiment, reduced to 12 azimuths, with the goals of issue 25 as assertions."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.binaural import HrirSet
from aiogenomix.components.binaural.experiment import (
    ExperimentConfig, folded, offset_azimuths, run_experiment, summarise,
)


def test_offset_azimuths_avoid_every_measured_direction() -> None:
    azimuths = offset_azimuths(72)
    assert len(azimuths) == 72 and np.all(np.mod(azimuths, 5.0) == 2.5)
    assert list(offset_azimuths(12)[:3]) == [15.0, 45.0, 75.0]
    assert folded([10.0, 170.0, -100.0, 90.0]) == pytest.approx([10.0, 10.0, -80.0, 90.0])


def test_twelve_azimuths_meet_the_goals(kemar: HrirSet) -> None:
    config = ExperimentConfig(azimuths=tuple(offset_azimuths(12)), signals=("noise", "speech-like"), seed=25)
    results, _timing = run_experiment(config, hrirs=kemar)   # speed: ./run bench --only localisation
    summaries = summarise(results)
    assert [(s.signal, s.snr, s.cases) for s in summaries] == [
        ("noise", 20.0, 12), ("noise", 5.0, 12), ("speech-like", 20.0, 12), ("speech-like", 5.0, 12)]
    for summary in summaries:
        assert summary.static_lateral_median <= 5.0, summary
        assert summary.rotation_front_back <= 0.02, summary
        assert summary.rotation_median <= 5.0, summary
        # The head turning while the audio goes by, its azimuth known at every sample, does as well.
        assert summary.sweep_front_back <= 0.02, summary
        assert summary.sweep_median <= 5.0, summary
