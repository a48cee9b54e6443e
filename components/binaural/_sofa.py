"""HRIR sets in SOFA files (AES69, convention ``SimpleFreeFieldHRIR``): read any head's, write ours.

SOFA is the format every HRTF database ships in: a netCDF-4 file whose
``Data.IR`` holds M measurements × R receivers × N taps, with the sources'
positions (``SourcePosition``, spherical in degrees and metres or Cartesian in
metres) relative to a listener looking along ``ListenerView``. The files are read
and written with ``netCDF4`` (the ``sofa`` extra: ``pip install aiogenomix[sofa]``),
imported only here. Every check a damaged or foreign file fails raises
:class:`SofaError` naming the file and what is wrong, before any of it is used.

Read: two receivers (the left is the one at positive y, whichever order the
file keeps), one sampling rate, ``Data.Delay`` added as leading zeros, azimuths
made relative to ``ListenerView``. :func:`read_sofa` takes heads and refuses a
measured room by name; :func:`read_sofa_room` takes measured rooms
(:data:`ROOM_CONVENTIONS`, see :mod:`._measured_room`).
"""

from __future__ import annotations

import datetime
import os
import pathlib
from typing import Any

import numpy as np
import numpy.typing as npt

from ._errors import HrirError
from ._hrir_set import HrirSet, wrap_degrees
from ._measured_room import MeasuredRoom

__all__ = ["SofaError", "read_sofa", "read_sofa_room", "write_sofa", "SOFA_CONVENTION", "ROOM_CONVENTIONS"]

#: The convention of a head's free-field impulse responses.
SOFA_CONVENTION = "SimpleFreeFieldHRIR"
#: The conventions of measured rooms (binaural room impulse responses with head orientations).
ROOM_CONVENTIONS = ("MultiSpeakerBRIR", "SingleRoomMIMOSRIR", "SingleRoomSRIR")
#: The longest response accepted (a head's response is a few milliseconds; this is 2.7 s at 48 kHz).
_MAX_TAPS = 131_072


class SofaError(HrirError):
    """A SOFA file that cannot be used as a head: unreadable, of another convention, or inconsistent."""


def _netcdf() -> Any:
    try:
        import netCDF4
    except ImportError as exc:
        raise SofaError("reading SOFA files needs the netCDF4 package: pip install 'aiogenomix[sofa]'") from exc
    return netCDF4


def read_sofa(path: str | os.PathLike[str], *, shown: str | None = None) -> HrirSet:
    """The HRIR set of a SOFA file of convention ``SimpleFreeFieldHRIR``.

    Args:
        path: The file.
        shown: How to name it in messages and in the set's ``source`` (default: *path*).

    Raises:
        SofaError: when the file is not SOFA, not of that convention, or inconsistent.
    """
    name = shown if shown is not None else os.fspath(path)
    netcdf = _netcdf()
    try:
        dataset = netcdf.Dataset(os.fspath(path), "r")
    except (OSError, RuntimeError, ValueError) as exc:
        raise SofaError(f"{name!r} is not a SOFA file (SOFA is netCDF-4): {exc}") from None
    with dataset:
        dataset.set_auto_mask(False)
        return _read(dataset, name)


def _attribute(dataset: Any, key: str) -> str:
    return str(dataset.getncattr(key)) if key in dataset.ncattrs() else ""


def _variable(dataset: Any, name: str, key: str, *, required: bool = True) -> npt.NDArray[np.float64] | None:
    if key not in dataset.variables:
        if required:
            raise SofaError(f"{name!r} has no {key} (a SimpleFreeFieldHRIR file must)")
        return None
    try:
        values = np.asarray(dataset.variables[key][:], dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise SofaError(f"{name!r}: {key} is not numeric ({exc})") from None
    if not np.all(np.isfinite(values)):
        raise SofaError(f"{name!r}: {key} holds values that are not finite")
    return values


def _spherical(dataset: Any, name: str, key: str) -> npt.NDArray[np.float64]:
    """``(rows, 3)`` azimuth (°), elevation (°) and distance (m) of a position variable."""
    values = _variable(dataset, name, key)
    assert values is not None
    values = values.reshape(-1, values.shape[-1]) if values.ndim > 1 else values.reshape(1, -1)
    if values.shape[1] != 3:
        raise SofaError(f"{name!r}: {key} has {values.shape[1]} coordinates, not 3")
    kind = str(getattr(dataset.variables[key], "Type", "spherical")).lower()
    if kind == "cartesian":
        x, y, z = values.T
        horizontal = np.hypot(x, y)
        return np.stack([np.degrees(np.arctan2(y, x)), np.degrees(np.arctan2(z, horizontal)), np.hypot(horizontal, z)],
                        axis=1)
    if kind != "spherical":
        raise SofaError(f"{name!r}: {key} is of type {kind!r}; SOFA positions are spherical or cartesian")
    return values


def _convention(dataset: Any, name: str, wanted: tuple[str, ...]) -> str:
    """The file's SOFA convention, if one of *wanted*, after checking it is SOFA and FIR at all."""
    if _attribute(dataset, "Conventions") != "SOFA":
        raise SofaError(f"{name!r} is netCDF but not SOFA (its Conventions attribute is "
                        f"{_attribute(dataset, 'Conventions')!r}, not 'SOFA')")
    convention = _attribute(dataset, "SOFAConventions")
    if convention not in wanted:
        if wanted == (SOFA_CONVENTION,):
            hint = " (a measured room: not a head)" if convention in ROOM_CONVENTIONS else ""
            raise SofaError(f"{name!r} is of SOFA convention {convention!r}{hint}; a head is {SOFA_CONVENTION!r}")
        raise SofaError(f"{name!r} is of SOFA convention {convention!r}; a measured room is one of "
                        f"{', '.join(wanted)}")
    if _attribute(dataset, "DataType") not in ("FIR", "FIR-E", ""):     # FIR-E: delays per emitter
        raise SofaError(f"{name!r} holds DataType {_attribute(dataset, 'DataType')!r}, not FIR impulse responses")
    return convention


def _rate(dataset: Any, name: str) -> float:
    rates = _variable(dataset, name, "Data.SamplingRate")
    assert rates is not None
    if rates.size < 1 or not np.all(rates == rates.ravel()[0]) or not 1000.0 <= rates.ravel()[0] <= 768_000.0:
        raise SofaError(f"{name!r}: Data.SamplingRate must be one rate between 1 kHz and 768 kHz, not {rates.ravel()}")
    return float(rates.ravel()[0])


def _left_first(dataset: Any, name: str) -> bool:
    """Whether the first receiver is the left ear (the one at positive y; the first, when the file does not say)."""
    receivers = _variable(dataset, name, "ReceiverPosition", required=False)
    if receivers is None or receivers.size < 6:
        return True
    y = receivers.reshape(2, 3, -1)[:, 1, 0] if receivers.ndim == 3 else receivers.reshape(2, -1)[:, 1]
    return bool(y[0] >= y[1])


def _read(dataset: Any, name: str) -> HrirSet:
    _convention(dataset, name, (SOFA_CONVENTION,))
    ir = _variable(dataset, name, "Data.IR")
    assert ir is not None
    if ir.ndim != 3 or ir.shape[1] != 2 or ir.shape[0] < 1 or not 8 <= ir.shape[2] <= _MAX_TAPS:
        raise SofaError(f"{name!r}: Data.IR is {ir.shape}; a head's is measurements × 2 ears × 8 to "
                        f"{_MAX_TAPS} taps")
    rate = _rate(dataset, name)
    sources = _spherical(dataset, name, "SourcePosition")
    if len(sources) == 1 and ir.shape[0] > 1:
        raise SofaError(f"{name!r}: {ir.shape[0]} measurements share one SourcePosition")
    if len(sources) != ir.shape[0]:
        raise SofaError(f"{name!r}: {len(sources)} source positions for {ir.shape[0]} measurements")
    taps = ir.transpose(0, 2, 1)                                                     # (M, N, R)
    if not _left_first(dataset, name):
        taps = taps[:, :, ::-1]
    delay = _variable(dataset, name, "Data.Delay", required=False)
    if delay is not None and np.any(delay != 0):
        samples = np.broadcast_to(np.round(delay).astype(np.int64).reshape(-1, 2), (len(taps), 2))
        if np.any(samples < 0) or samples.max() > _MAX_TAPS:
            raise SofaError(f"{name!r}: Data.Delay must be whole non-negative samples, not {delay.ravel()[:4]}")
        shifted = np.zeros((len(taps), taps.shape[1] + int(samples.max()), 2))
        for ear in range(2):
            for m in range(len(taps)):
                shifted[m, samples[m, ear]:samples[m, ear] + taps.shape[1], ear] = taps[m, :, ear]
        taps = shifted
    view = _spherical(dataset, name, "ListenerView") if "ListenerView" in dataset.variables else np.zeros((1, 3))
    azimuth = wrap_degrees(sources[:, 0] - view[0, 0])
    if not np.any(taps):
        raise SofaError(f"{name!r}: every impulse response is silent")
    title = _attribute(dataset, "Title") or _attribute(dataset, "DatabaseName") or pathlib.Path(name).name
    return HrirSet(rate, azimuth, sources[:, 1].copy(), np.ascontiguousarray(taps), f"{title} (SOFA)")


def read_sofa_room(path: str | os.PathLike[str], *, shown: str | None = None) -> MeasuredRoom:
    """The binaural room impulse responses of a SOFA file of a measured room (:data:`ROOM_CONVENTIONS`).

    Each response's head azimuth is its ``ListenerView`` (one per measurement, or one for all);
    its emitter is the loudspeaker index (``MultiSpeakerBRIR``, ``SingleRoomMIMOSRIR``) or, for
    ``SingleRoomSRIR``, the index of its ``SourcePosition`` among the distinct ones.

    Raises:
        SofaError: when the file is not SOFA, not of those conventions, not binaural, or inconsistent.
    """
    name = shown if shown is not None else os.fspath(path)
    netcdf = _netcdf()
    try:
        dataset = netcdf.Dataset(os.fspath(path), "r")
    except (OSError, RuntimeError, ValueError) as exc:
        raise SofaError(f"{name!r} is not a SOFA file (SOFA is netCDF-4): {exc}") from None
    with dataset:
        dataset.set_auto_mask(False)
        convention = _convention(dataset, name, ROOM_CONVENTIONS)
        ir = _variable(dataset, name, "Data.IR")
        assert ir is not None
        if convention == "MultiSpeakerBRIR" and ir.ndim == 4:
            ir = ir.transpose(0, 1, 3, 2)                                            # M R E N -> M R N E
        elif ir.ndim == 3:
            ir = ir[..., np.newaxis]                                                 # one emitter
        if ir.ndim != 4 or ir.shape[1] != 2 or not 8 <= ir.shape[2] <= 8 * _MAX_TAPS:
            raise SofaError(f"{name!r}: Data.IR is {ir.shape}; a measured room for a head has 2 receivers "
                            "and 8 or more taps")
        measurements, _, length, emitters = ir.shape
        delay = _variable(dataset, name, "Data.Delay", required=False)
        if delay is not None and np.any(delay != 0):
            raise SofaError(f"{name!r}: a measured room's Data.Delay must be 0 (its delays are in its responses)")
        if not _left_first(dataset, name):
            ir = ir[:, ::-1]
        views = (_spherical(dataset, name, "ListenerView")[:, 0] if "ListenerView" in dataset.variables
                 else np.zeros(1))
        if len(views) not in (1, measurements):
            raise SofaError(f"{name!r}: {len(views)} listener views for {measurements} measurements")
        views = np.broadcast_to(wrap_degrees(views), (measurements,))
        if convention == "SingleRoomSRIR":
            places = _variable(dataset, name, "SourcePosition")
            assert places is not None
            places = places.reshape(-1, 3) if places.size % 3 == 0 else places
            if len(places) not in (1, measurements):
                raise SofaError(f"{name!r}: {len(places)} source positions for {measurements} measurements")
            _, emitter = np.unique(np.broadcast_to(places, (measurements, 3)), axis=0, return_inverse=True)
            emitter_of = np.asarray(emitter).reshape(-1).astype(np.int64)
            taps = ir[..., 0].transpose(0, 2, 1)
            view_of = np.asarray(views, dtype=np.float64)
        else:
            taps = ir.transpose(0, 3, 2, 1).reshape(measurements * emitters, length, 2)   # (M·E, N, 2)
            emitter_of = np.tile(np.arange(emitters, dtype=np.int64), measurements)
            view_of = np.repeat(np.asarray(views, dtype=np.float64), emitters)
        if not np.any(taps):
            raise SofaError(f"{name!r}: every impulse response is silent")
        title = _attribute(dataset, "Title") or _attribute(dataset, "DatabaseName") or pathlib.Path(name).name
        return MeasuredRoom(_rate(dataset, name), emitter_of, view_of, np.ascontiguousarray(taps),
                            f"{title} (SOFA {convention})")


def write_sofa(hrirs: HrirSet, path: str | os.PathLike[str], *, title: str | None = None,
               distance: float = 1.4) -> None:
    """Write *hrirs* as a SOFA file of convention ``SimpleFreeFieldHRIR`` 1.0 (AES69-2022).

    Args:
        hrirs: The set.
        path: The file to write (replaced if it exists).
        title: The file's title (default: the set's ``source``).
        distance: The sources' distance in the file, metres (the MIT KEMAR's was 1.4 m).
    """
    netcdf = _netcdf()
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M:%S")
    with netcdf.Dataset(os.fspath(path), "w", format="NETCDF4") as out:
        attributes = {
            "Conventions": "SOFA", "Version": "2.1", "SOFAConventions": SOFA_CONVENTION,
            "SOFAConventionsVersion": "1.0", "APIName": "aiogenomix", "APIVersion": "1.0", "DataType": "FIR",
            "RoomType": "free field", "Title": title or hrirs.source or "HRIRs", "DateCreated": now,
            "DateModified": now, "AuthorContact": "", "Organization": "", "License": "No license provided",
            "ApplicationName": "aiogenomix", "ApplicationVersion": "1.0", "DatabaseName": "",
            "ListenerShortName": "", "Comment": "", "History": "", "References": "", "Origin": hrirs.source,
        }
        out.setncatts(attributes)
        count, length = len(hrirs), hrirs.length
        for dimension, size in (("I", 1), ("C", 3), ("R", 2), ("E", 1), ("N", length), ("M", count), ("S", 0)):
            out.createDimension(dimension, size)

        def variable(key: str, dims: tuple[str, ...], values: npt.ArrayLike, **attrs: str) -> None:
            created = out.createVariable(key, "f8", dims)
            created[:] = values
            created.setncatts(attrs)

        variable("ListenerPosition", ("I", "C"), [[0.0, 0.0, 0.0]], Type="cartesian", Units="metre")
        variable("ReceiverPosition", ("R", "C", "I"), [[[0.0], [0.09], [0.0]], [[0.0], [-0.09], [0.0]]],
                 Type="cartesian", Units="metre")
        variable("SourcePosition", ("M", "C"),
                 np.stack([hrirs.azimuth % 360.0, hrirs.elevation, np.full(count, distance)], axis=1),
                 Type="spherical", Units="degree, degree, metre")
        variable("EmitterPosition", ("E", "C", "I"), [[[0.0], [0.0], [0.0]]], Type="cartesian", Units="metre")
        variable("ListenerUp", ("I", "C"), [[0.0, 0.0, 1.0]], Type="cartesian", Units="metre")
        variable("ListenerView", ("I", "C"), [[1.0, 0.0, 0.0]], Type="cartesian", Units="metre")
        variable("Data.IR", ("M", "R", "N"), hrirs.taps.transpose(0, 2, 1))
        variable("Data.SamplingRate", ("I",), [hrirs.rate], Units="hertz")
        variable("Data.Delay", ("I", "R"), [[0.0, 0.0]])
