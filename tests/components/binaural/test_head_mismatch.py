"""``examples/head_mismatch.py``: where each band hears a talker, on the templates' own head and on another."""

from __future__ import annotations

import importlib.util
import pathlib
import types

import numpy as np

from aiogenomix.components.binaural import HrirSet, LocaliserSetup, SourceLocaliser, snowman_hrirs

EXAMPLE = pathlib.Path(__file__).resolve().parents[3] / "examples" / "head_mismatch.py"


def load_example() -> types.ModuleType:
    spec = importlib.util.spec_from_file_location("head_mismatch", EXAMPLE)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_templates_head_is_heard_where_it_is_and_the_snowman_nearer_the_median_plane(kemar: HrirSet) -> None:
    example = load_example()
    localiser = SourceLocaliser(LocaliserSetup(rate=example.RATE))
    centres = example.band_centres(localiser)
    assert 100.0 <= centres[0] < centres[-1] <= 5000.0
    for azimuth in (30.0, 60.0):
        own = example.band_directions(localiser, kemar, azimuth)
        # Above the lowest bands (the diffuse field's), every band of the templates' own head points at the talker.
        assert np.all(np.abs(own.lateral[centres > 400.0] - azimuth) <= 5.0), own.lateral
        assert np.isclose(own.weight.sum(), 1.0)
    other = example.band_directions(localiser, snowman_hrirs(), 60.0)
    # Speech puts most of the weight below 1.1 kHz; there the snowman's talker at 60° is heard well short of it.
    low = centres < 1100.0
    assert other.weight[low].sum() > 0.8
    assert np.average(other.lateral[low], weights=other.weight[low]) < 55.0
