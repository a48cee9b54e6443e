"""Fixtures of the binaural tests: the KEMAR set, loaded once per test process."""

from __future__ import annotations

import pytest

from aiogenomix.components.binaural import HrirSet, load_kemar


@pytest.fixture(scope="session")
def kemar() -> HrirSet:
    """The MIT KEMAR set (the user's cache, converted from slab's file on the first use)."""
    return load_kemar()
