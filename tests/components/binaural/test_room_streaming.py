"""The room renderer's shortcuts give what they stand for: the late convolver a plain convolution, the early
reflections kept up to date as the head turns those made afresh, their band responses the seven bands'.
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from aiogenomix.components.binaural._convolution import StagedLateConvolver


def test_the_late_convolver_is_a_convolution_whatever_the_calls_sizes() -> None:
    rng = np.random.default_rng(1)
    tails = rng.standard_normal((3, 20_000, 2))
    tails[:, :1024] = 0.0                                # silent for its first block, as a late tail is
    late = StagedLateConvolver(tails, 1024)
    dry = rng.standard_normal((3, 30_000))
    cuts = [0, 1, 700, 2205, 5000, 9000, 9001, 30_000]   # calls shorter and longer than every stage's block
    out = np.concatenate([late.convolve(dry[:, a:b]) for a, b in zip(cuts[:-1], cuts[1:], strict=True)])
    expected = sum(np.stack([signal.fftconvolve(dry[i], tails[i, :, ear])[:30_000] for ear in range(2)], axis=1)
                   for i in range(3))
    assert np.max(np.abs(out - expected)) < 1e-9 * np.max(np.abs(expected))
