"""The gateway's copy of a remote component's out ports, kept up to date by the port messages.

A :class:`MirroredOutPort` is an :class:`~aiogenomix.components.core.OutPortRuntime`, so the read and
watch routes serve it as they serve a local port, as long as its host is heard from (its proxy says
so: beyond the stale bound a read answers ``::genom::remote_io`` rather than an old value), and an in
port of this process connected to it reads it the same way.  Data the remote component withdrew (a
sensor down) is withdrawn here too, with the component's reason.  Its data is already encoded
(JSON-ready, arrays as numpy arrays), so its type encodes nothing again.  Numbered data (the audio
window) is held as a :class:`MirroredWindow`: the chunks of every publication arrive once, are kept as
long as the remote window holds them, and answer whole reads, ``since=`` reads and watchers exactly as
the remote port would, counting the items that never arrived as lost.  What a window holds is
reserved against this process's audio ledger (``--max-audio-bytes``): a window that does not fit is
not kept, and its reads are refused naming the flag, until it fits.
"""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from ..components.core import (
    Chunk, ChunkedArray, GenomException, Ledger, OutPort, OutPortRuntime, OverBudget, Reservation,
)
from ._wire import arrays_of

if TYPE_CHECKING:
    from ._proxy import RemoteInstance

__all__ = ["MirroredOutPort", "MirroredWindow", "remote_exception"]

#: Seconds between two tries of a window that did not fit the ledger (each asks the host for the whole window).
REFIT_PERIOD = 5.0


class RemoteException(GenomException):
    """An exception of a component of another process, with its id and detail as its host sent them.

    Args:
        encoded: The detail as the remote component encoded it (None: none).
    """

    def __init__(self, encoded: dict[str, Any] | None = None) -> None:
        super().__init__()
        # Not an annotated member: those are the detail members of a declared exception.
        self.remote_detail = encoded

    def encoded_detail(self) -> dict[str, Any] | None:
        """The detail as the remote component encoded it."""
        return self.remote_detail


_REMOTE_EXCEPTIONS: dict[str, type[RemoteException]] = {}


def remote_exception(body: dict[str, Any]) -> GenomException:
    """The exception whose object (``{"ex": "::world::SENSOR_DOWN", "detail": {...}}``) a host sent.

    Its id stays the remote component's, whoever reports it (a read's 503, a service that read it).
    """
    ex = str(body.get("ex") or "::genom::unkex")
    scope, _, name = ex.strip(":").rpartition("::")
    klass = _REMOTE_EXCEPTIONS.get(ex)
    if klass is None:
        klass = type(name or "unkex", (RemoteException,), {"scope": scope or "genom", "__doc__": f"{ex}, remote"})
        if len(_REMOTE_EXCEPTIONS) < 256:  # ids come from hosts: kept, but not without bound
            _REMOTE_EXCEPTIONS[ex] = klass
    detail = body.get("detail")
    exc = klass(detail if isinstance(detail, dict) else None)
    exc.args = (f"{ex} {detail}" if exc.remote_detail else ex,)
    return exc


@dataclasses.dataclass(frozen=True)
class _Entry:
    """The elements one message added to each array of the window, and the items they are.

    ``first`` and ``last`` number the items (None for a window's zero padding, which no item owns).
    """

    first: int | None
    last: int | None
    chunks: tuple[Chunk, ...]
    #: The bytes its chunks hold.
    nbytes: int = dataclasses.field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "nbytes", sum(chunk.array.nbytes for chunk in self.chunks))

    @property
    def items(self) -> int:
        """How many items the message added (0 for padding)."""
        return 0 if self.first is None or self.last is None else self.last - self.first + 1


def _chunk(array: np.ndarray) -> Chunk:
    flat = array.reshape(-1)
    if flat.flags.writeable:
        flat = flat.copy()
        flat.flags.writeable = False
    return Chunk(flat)


class MirroredWindow:
    """Numbered data of one publication of a remote port, rebuilt from the messages' chunks.

    Implements :class:`~aiogenomix.components.core.Incremental` and
    :class:`~aiogenomix.components.core.Chunked` as the remote data does.

    Args:
        whole: The whole data's skeleton (arrays as ``{"$len": n}``).
        entries: The kept entries, oldest first.
        index: The newest item.
        items_per_publication: Items the last publication added.
        counts: Members of *whole* that count the elements of an array (by array number).
        dtypes: The dtype of each array.
    """

    def __init__(self, whole: Any, entries: tuple[_Entry, ...], index: int, items_per_publication: int,
                 counts: dict[str, int], dtypes: tuple[np.dtype[Any], ...]) -> None:
        self._whole = whole
        self._entries = entries
        self.index = index
        self.items_per_publication = max(1, items_per_publication)
        self._counts = counts
        self._dtypes = dtypes

    def _whole_chunks(self) -> list[list[Chunk]]:
        lengths: list[Any] = []
        arrays_of(_lengths_as_arrays(self._whole), lengths)
        picked: list[list[Chunk]] = []
        for number, wanted in enumerate(len(x) for x in lengths):
            chunks: list[Chunk] = []
            have = 0
            for entry in reversed(self._entries):
                if have >= wanted:
                    break
                chunk = entry.chunks[number]
                if have + len(chunk) > wanted:
                    chunk = Chunk(chunk.array[have + len(chunk) - wanted:])
                chunks.append(chunk)
                have += len(chunk)
            picked.append(chunks[::-1])
        return picked

    def _chunks_since(self, since: int) -> tuple[list[list[Chunk]], int]:
        wanted_items = max(0, self.index - since)
        picked: list[list[Chunk]] = [[] for _ in self._dtypes]
        present = 0
        for entry in self._entries:
            if entry.last is None or entry.first is None or entry.last <= since:
                continue
            skip = max(0, since + 1 - entry.first)
            present += entry.items - skip
            for number, chunk in enumerate(entry.chunks):
                per_item = len(chunk) // entry.items
                picked[number].append(Chunk(chunk.array[skip * per_item:]) if skip else chunk)
        return picked, max(0, wanted_items - present)

    def chunked(self, since: int | None = None) -> tuple[Any, int]:
        """The data with its arrays as :class:`ChunkedArray` (the whole window, or the items after *since*)."""
        if since is None:
            picked, lost = self._whole_chunks(), 0
        else:
            picked, lost = self._chunks_since(since)
        arrays = [ChunkedArray(chunks, dtype) for chunks, dtype in zip(picked, self._dtypes, strict=True)]
        data = _with_arrays(self._whole, iter(arrays))
        if since is not None and isinstance(data, dict):
            for member, number in self._counts.items():
                data[member] = arrays[number].size
        return data, lost

    def whole(self) -> Any:
        """The whole data with its arrays joined, as the remote port published it (padding included)."""
        return _joined(self.chunked()[0])

    def since(self, index: int) -> tuple[Any, int]:
        """The items after *index* with their arrays joined, and how many of them are lost."""
        data, lost = self.chunked(index)
        return _joined(data), lost


def _lengths_as_arrays(whole: Any) -> Any:
    """*whole* with each ``{"$len": n}`` as a zero array of length n (to walk arrays in order)."""
    if isinstance(whole, dict):
        if len(whole) == 1 and "$len" in whole:
            return np.empty(whole["$len"], np.int8)
        return {key: _lengths_as_arrays(item) for key, item in whole.items()}
    if isinstance(whole, list):
        return [_lengths_as_arrays(item) for item in whole]
    return whole


def _with_arrays(whole: Any, arrays: Any) -> Any:
    if isinstance(whole, dict):
        if len(whole) == 1 and "$len" in whole:
            return next(arrays)
        return {key: _with_arrays(item, arrays) for key, item in whole.items()}
    if isinstance(whole, list):
        return [_with_arrays(item, arrays) for item in whole]
    return whole


def _joined(data: Any) -> Any:
    if isinstance(data, ChunkedArray):
        return data.numpy()
    if isinstance(data, dict):
        return {key: _joined(item) for key, item in data.items()}
    if isinstance(data, list):
        return [_joined(item) for item in data]
    return data


class MirroredOutPort(OutPortRuntime[Any]):
    """A remote out port as the gateway holds it: updated by :meth:`apply`, read like a local port.

    Args:
        described: The port's description in the remote ``/info``.
        owner: The proxy of the remote component.
        ledger: Where a window's bytes are held (the gateway's audio ledger); None: not held.
    """

    owner: RemoteInstance

    def __init__(self, described: dict[str, Any], owner: RemoteInstance, ledger: Ledger | None = None) -> None:
        super().__init__(OutPort.from_description(described, "mirrored"), owner)
        self._entries: tuple[_Entry, ...] = ()
        self._index = 0
        self._counts: dict[str, int] = {}
        self._ledger = ledger
        self._reservation: Reservation | None = None
        #: Why the window is not kept (it did not fit the ledger), until it fits; and when to try again.
        self.refused: OverBudget | None = None
        self._refit_at = 0.0
        #: Messages that did not follow the previous one (items the gateway never got).
        self.gaps = 0

    @property
    def index(self) -> int:
        """The newest item the window holds (0: none, or no numbered data)."""
        return self._index

    def read(self, name: str | None = None) -> Any:
        """The data as the host last published it, while the host is heard from.

        Raises:
            RemoteUnreachable: when the host was not heard from within the stale bound.
            PortUnavailable: when the remote component withdrew the data (its reason).
            OverBudget: when the window does not fit this process's audio ledger.
        """
        self.owner.check_heard()
        if self.refused is not None:
            raise self.refused
        return super().read(name)

    def read_kept(self, name: str | None = None) -> Any:
        """The data as the host last published it, however old (not withdrawn)."""
        return super().read(name)

    def read_as(self, kind: Any, name: str | None = None) -> Any:
        """The data decoded as type *kind* (for an in port of this process connected here), as :meth:`read`."""
        value = self.read(name)
        if isinstance(value, MirroredWindow):
            value = value.whole()
        return None if value is None else kind.decode(value, self.name)

    def release(self) -> None:
        """Give back what the window holds against the ledger (the proxy stops)."""
        if self._reservation is not None:
            self._reservation.release()
            self._reservation = None

    def _hold(self, entries: tuple[_Entry, ...]) -> bool:
        """Hold the bytes of *entries* against the ledger; False when they do not fit (nothing is kept then)."""
        if self._ledger is None:
            return True
        amount = sum(entry.nbytes for entry in entries)
        what = f"the gateway's copy of {self.owner.instance}/{self.name}, a window of {amount} bytes"
        try:
            if self._reservation is None:
                self._reservation = self._ledger.reserve(amount, f"{self.owner.instance}/{self.name}", what)
            else:
                self._reservation.resize(amount, what)
        except OverBudget as exc:
            self.release()
            self.refused, self._refit_at = exc, time.monotonic() + REFIT_PERIOD
            self._entries, self._index, self._value = (), 0, None
            self.changed()  # its readers and watchers learn it now
            return False
        self.refused = None
        return True

    def apply(self, header: dict[str, Any], whole: Any, delta: Any) -> bool:
        """Take one port message; return False when it does not follow the previous one (ask for a base).

        A message that does not follow is still taken: its items are kept, the missing ones
        are counted as lost by the readers that ask for them.  While a window does not fit the
        ledger, its messages are dropped, and a base is asked for every ``REFIT_PERIOD`` seconds.
        """
        kind = header.get("kind", "value")
        if kind == "withdrawn":
            self.withdraw(remote_exception(header.get("reason") or {}))
            return True
        self.withdrawn = None  # published again: current again
        if kind == "value":
            if self.spec.multiple:
                self._elements[header["element"]] = delta
            else:
                self._value = delta
            self.changed()
            return True
        if self.refused is not None and kind != "base":
            if time.monotonic() < self._refit_at:
                return True
            self._refit_at = time.monotonic() + REFIT_PERIOD
            return False  # the proxy asks for the whole window again: it may fit now
        arrays: list[Any] = []
        arrays_of(delta, arrays)
        dtypes = tuple(np.asarray(a).dtype for a in arrays)
        index, prev = int(header["index"]), int(header.get("prev", 0))
        self._counts = header.get("counts") or self._counts
        follows = True
        entries: tuple[_Entry, ...]
        if kind == "base":
            held = header["held"]
            padding = _Entry(None, None, tuple(_chunk(a[:len(a) - h]) for a, h in zip(arrays, held, strict=True)))
            items = int(header["items"])
            numbered = _Entry(index - items + 1, index, tuple(_chunk(a[len(a) - h:])
                                                               for a, h in zip(arrays, held, strict=True)))
            entries = (padding, numbered) if items else (padding,)
        else:
            follows = prev == self._index
            if not follows:
                self.gaps += 1
            entry = _Entry(prev + 1, index, tuple(_chunk(a) for a in arrays))
            entries = _trimmed((*self._entries, entry), whole) if index > prev else self._entries
        if not self._hold(entries):
            return True  # refused: said to the readers; a base is asked for later
        self._entries, self._index = entries, index
        self._value = MirroredWindow(whole, entries, index, index - prev if kind != "base" else 1,
                                     dict(self._counts), dtypes)
        self.changed()
        return follows


def _trimmed(entries: tuple[_Entry, ...], whole: Any) -> tuple[_Entry, ...]:
    """Drop the oldest entries the whole window no longer needs (it holds what the remote window holds)."""
    lengths: list[Any] = []
    arrays_of(_lengths_as_arrays(whole), lengths)
    wanted = [len(x) for x in lengths]
    totals = [sum(len(e.chunks[n]) for e in entries) for n in range(len(wanted))]
    start = 0
    while start < len(entries) - 1 and all(
        total - len(entries[start].chunks[n]) >= wanted[n] for n, total in enumerate(totals)
    ):
        totals = [total - len(entries[start].chunks[n]) for n, total in enumerate(totals)]
        start += 1
    kept = entries[start:]
    oldest = kept[0]
    if oldest.items and oldest.first is not None:
        # The oldest entry may reach back past the window (a publication of several items): its
        # items the remote window no longer holds are lost for a since= reader there too.
        per_item = [len(chunk) // oldest.items for chunk in oldest.chunks]
        excess = min(((total - want) // each for total, want, each in zip(totals, wanted, per_item, strict=True)
                      if each), default=0)
        if 0 < excess < oldest.items:
            sliced = tuple(Chunk(chunk.array[excess * each:]) for chunk, each in zip(oldest.chunks, per_item,
                                                                                     strict=True))
            kept = (_Entry(oldest.first + excess, oldest.last, sliced), *kept[1:])
    return kept
