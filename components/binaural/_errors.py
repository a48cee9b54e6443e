"""The exceptions of the binaural library: one tree, rooted at :class:`BinauralError`."""

from __future__ import annotations

__all__ = ["BinauralError", "HrirError", "HrirUnavailable", "LocalisationError"]


class BinauralError(Exception):
    """Base of every error raised by :mod:`aiogenomix.components.binaural`."""


class HrirError(BinauralError, ValueError):
    """An HRIR set or a use of it that makes no sense (shapes, rates, directions)."""


class HrirUnavailable(BinauralError):
    """The measured HRIRs cannot be read (the package that ships them is missing or damaged)."""


class LocalisationError(BinauralError, ValueError):
    """Localisation parameters or audio that make no estimate (an empty band, too few samples)."""
