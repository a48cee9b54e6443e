"""The MIT KEMAR HRIRs (Gardner & Martin 1995), read offline from the ``slab`` package and cached as .npz.

``slab`` ships the measurements as a bz2-compressed pickle of its own classes,
so reading them needs ``slab`` imported (two seconds, matplotlib included, and
it appends to ``sys.path``). That happens once per user: the directions and taps
are then kept as a compressed ``.npz`` of 1.4 MB in the user's cache directory, and
every later process reads that in milliseconds without importing ``slab``.
Nothing is ever downloaded. The data are "provided without any usage
restrictions"; cite Gardner & Martin, MIT Media Lab Perceptual Computing
Technical Report #280 (1994).
"""

from __future__ import annotations

import functools
import importlib.metadata
import importlib.util
import os
import pathlib
import tempfile
import warnings

import numpy as np

from ._errors import HrirUnavailable
from ._hrir_set import HrirSet, wrap_degrees

__all__ = ["load_kemar", "kemar_cache_path", "KEMAR_RATE"]

#: The sample rate of the measurements.
KEMAR_RATE = 44_100.0
_DATA_FILE = "mit_kemar_normal_pinna.bz2"
_SOURCE = "MIT KEMAR, normal pinna (Gardner & Martin 1995)"


def _default_cache_dir() -> pathlib.Path:
    explicit = os.environ.get("AIOGENOMIX_CACHE_DIR")
    if explicit:
        return pathlib.Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return pathlib.Path(base) / "aiogenomix"


def _data_file() -> pathlib.Path:
    # find_spec locates the package without importing it (importing slab costs seconds).
    spec = importlib.util.find_spec("slab")
    if spec is None or not spec.submodule_search_locations:
        raise HrirUnavailable("the KEMAR HRIRs come with the 'slab' package, which is not installed "
                              "(it is a dependency of aiogenomix: reinstall the package)")
    path = pathlib.Path(next(iter(spec.submodule_search_locations))) / "data" / _DATA_FILE
    if not path.is_file():
        raise HrirUnavailable(f"the 'slab' package has no {_DATA_FILE} (looked in {path.parent})")
    return path


def kemar_cache_path(cache_dir: str | os.PathLike[str] | None = None) -> pathlib.Path:
    """Where the converted KEMAR set is (or will be) cached.

    The name carries ``slab``'s version and the data file's size, so a different
    copy of the data is converted again rather than confused with the cached one.

    Args:
        cache_dir: The directory (default: ``$AIOGENOMIX_CACHE_DIR``, else
            ``$XDG_CACHE_HOME/aiogenomix``, else ``~/.cache/aiogenomix``).

    Raises:
        HrirUnavailable: when ``slab`` or its data file is missing.
    """
    data = _data_file()
    version = importlib.metadata.version("slab")
    directory = pathlib.Path(cache_dir) if cache_dir is not None else _default_cache_dir()
    return directory / f"mit-kemar-slab{version}-{data.stat().st_size}.npz"


def load_kemar(cache_dir: str | os.PathLike[str] | None = None, *, use_cache: bool = True) -> HrirSet:
    """The MIT KEMAR HRIRs: 710 directions, 512 taps, 44.1 kHz, azimuth positive to the left.

    The first call in a process reads the cached .npz, or converts ``slab``'s file and
    writes the cache (atomically; an unwritable cache directory only costs the
    conversion next time). Later calls return the same object.

    Args:
        cache_dir: See :func:`kemar_cache_path`.
        use_cache: False converts from ``slab`` without reading or writing the cache.

    Raises:
        HrirUnavailable: when ``slab`` or its data file is missing or unreadable.
    """
    return _load(None if cache_dir is None else str(cache_dir), use_cache)


@functools.cache
def _load(cache_dir: str | None, use_cache: bool) -> HrirSet:
    if not use_cache:
        return _convert()
    path = kemar_cache_path(cache_dir)
    try:
        with np.load(path) as saved:
            return HrirSet(KEMAR_RATE, saved["azimuth"], saved["elevation"], saved["taps"].astype(np.float64), _SOURCE)
    except (OSError, KeyError, ValueError):
        pass  # no cache yet, or a damaged one: convert again and replace it
    hrirs = _convert()
    _write_cache(path, hrirs)
    return hrirs


def _convert() -> HrirSet:
    """Read slab's pickle through slab and keep plain arrays."""
    _data_file()
    try:
        with warnings.catch_warnings():
            # Whatever slab's imports say about their own dependencies is not our users' concern.
            warnings.simplefilter("ignore")
            import slab

            hrtf = slab.HRTF.kemar()
            polar = np.asarray(hrtf.sources.vertical_polar, dtype=np.float64)
            taps = np.stack([np.asarray(f.data, dtype=np.float64) for f in hrtf.data])
            rate = float(hrtf.samplerate)
    except Exception as exc:  # a broken install shows as anything from ImportError to UnpicklingError
        raise HrirUnavailable(f"cannot read the KEMAR HRIRs from slab: {exc!r}") from exc
    if rate != KEMAR_RATE or taps.ndim != 3 or taps.shape[2] != 2:
        raise HrirUnavailable(f"slab's KEMAR set is not as expected: {taps.shape} taps at {rate} Hz")
    return HrirSet(rate, wrap_degrees(polar[:, 0]), polar[:, 1].copy(), taps, _SOURCE)


def _write_cache(path: pathlib.Path, hrirs: HrirSet) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = tempfile.NamedTemporaryFile(dir=path.parent, prefix=path.stem, suffix=".tmp", delete=False)
    except OSError:
        return  # a read-only home: convert again next time
    try:
        with tmp:
            # The measurements are 16-bit: float32 keeps them exactly at half the size.
            np.savez_compressed(tmp, azimuth=hrirs.azimuth, elevation=hrirs.elevation,
                                taps=hrirs.taps.astype(np.float32))
        os.replace(tmp.name, path)   # concurrent first uses each write a whole file; the last one stays
    except OSError:
        pathlib.Path(tmp.name).unlink(missing_ok=True)
