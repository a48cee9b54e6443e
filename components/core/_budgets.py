"""Budgets: a bound on every resource a client can make a host hold, and the ledgers of those held in all.

A client names the size of what the gateway keeps for it: the audio port of a capture (rate, chunk
size and chunk count), the reply a dedicated-socket client leaves unread, a block of ``basc``, the
cameras of a world.  Each of these has a bound here, one typed value and one default each, which the
gateway fills from its command line (each bound names its flag).  A refusal says what was asked for,
the bound and the flag that changes it.

Bounds on one thing (one port, one world) are checked where it is asked for.  Bounds on everything
of a kind together are kept by a :class:`Ledger` of the host (``host.ledgers``): a component
reserves what it holds and releases it when done; a reservation that may be taken back (a slow
socket client's unsent reply) is evicted to make room for a new one, the one that has waited longest
without progress first (a client that reads, however slowly, goes after those that do not).
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Callable
from typing import Literal

from ._setting_groups import SettingsGroup, declared_settings, parse_amount, setting, whole_at_least

__all__ = ["Budgets", "BoundName", "OverBudget", "Ledger", "Reservation", "Ledgers", "MIB", "GIB", "size_text"]

MIB = 2**20
GIB = 2**30

#: The name of one bound (a field of :class:`Budgets`).
BoundName = Literal["port_bytes", "audio_bytes", "socket_clients", "socket_client_bytes", "socket_bytes",
                    "block_frames", "world_bytes", "render_bytes", "recording_bytes", "record_dir_bytes",
                    "recordings", "recording_seconds"]


def _bound(default: int, flag: str, unit: str, doc: str) -> int:
    """A bound: a setting of the limits section, a whole number (bytes also as ``64M``, ``1G``), 1 or more."""

    def amount(text: str) -> int:
        return parse_amount(text, unit)

    return setting(default, flag=flag, unit=unit, help=doc, parse=amount, refuse=whole_at_least(1),
                   metavar="BYTES" if unit == "bytes" else unit.upper())


def size_text(amount: int, unit: str = "bytes") -> str:
    """*amount* of *unit* for a person: ``64 MiB`` (bytes in binary multiples), ``4194304 frames``."""
    if unit != "bytes":
        return f"{amount} {unit}"
    for step, name in ((GIB, "GiB"), (MIB, "MiB"), (2**10, "KiB")):
        if amount >= step:
            value = amount / step
            return f"{value:.0f} {name}" if value == int(value) else f"{value:.1f} {name}"
    return f"{amount} bytes"


@dataclasses.dataclass(frozen=True)
class Budgets(SettingsGroup, section="limits", about="what one client can hold or send"):
    """The bound of every resource a client can make the components of a host hold.

    Each has a default here and a flag of the gateway (``aiogenomix-gateway --help``, group *limits*).
    Sizes are bytes (the flags also take ``64M``, ``1G``); ``docs/protocol.md`` (Budgets) lists
    them with what happens beyond each.  A bound on one thing larger than the bound on all of its
    kind together is that one in effect (one port cannot hold more than ``audio_bytes``).

    Attributes:
        port_bytes: One audio port (``capture``'s ``Port``, ``bass``'s ``Audio``): frames per chunk ×
            chunks × 2 channels × 4 bytes.  A larger ``StartCapture`` or ``Acquire`` is refused.
        audio_bytes: Every audio port and every ``basc`` block of the host together.
        socket_clients: Clients of one dedicated audio socket; one more gets an ``ERROR`` line.
        socket_client_bytes: Reply bytes one dedicated-socket client may hold unsent.  A reply that
            would be larger carries fewer chunks (2014 socket: the newest; the client counts the
            others lost) or frames (2015 socket: fewer than ``N``; its ``next`` says where to go on).
        socket_bytes: Reply bytes every dedicated-socket client of the host holds unsent, together.
            A reply that does not fit drops the clients whose replies have waited longest.
        block_frames: The largest block ``basc``'s ``GetBlocks`` collects (``nFramesPerBlock``).
        world_bytes: The render memory of one ``world`` (about 192 MiB and 128 bytes a camera pixel:
            ~700 MiB at 2048x2048).  A larger ``-size`` is refused at load.
        render_bytes: The render memory of every world of the host together.
        recording_bytes: One recording's file (``recorder``'s ``Start``), its summary included: the
            recording ends, readable, before the chunk that would pass it.
        record_dir_bytes: The files in one ``--record-dir`` directory together, the recordings being
            written included (measured when a recording starts there and none is being written).  A
            ``Start`` into a directory that holds this much is refused; a recording that would pass
            it ends, readable.
        recordings: Recordings running at once on the host (every ``recorder`` instance together).
        recording_seconds: One recording's runtime seconds: a ``duration`` longer than this is
            refused, and a recording until ``Stop`` ends here.
    """

    port_bytes: int = _bound(64 * MIB, "--max-port-bytes", "bytes", "one audio port (Port, Audio)")
    audio_bytes: int = _bound(256 * MIB, "--max-audio-bytes", "bytes",
                              "every audio port and basc block of the gateway together")
    socket_clients: int = _bound(64, "--max-socket-clients", "clients", "clients of one dedicated audio socket")
    socket_client_bytes: int = _bound(64 * MIB, "--max-socket-client-bytes", "bytes",
                                      "reply bytes one dedicated-socket client may hold unsent")
    socket_bytes: int = _bound(256 * MIB, "--max-socket-bytes", "bytes",
                               "reply bytes every dedicated-socket client holds unsent, together")
    block_frames: int = _bound(2**22, "--max-block-frames", "frames", "the largest block of basc's GetBlocks")
    world_bytes: int = _bound(1 * GIB, "--max-world-bytes", "bytes", "render memory of one world")
    render_bytes: int = _bound(2 * GIB, "--max-render-bytes", "bytes", "render memory of every world together")
    # An hour of binaural audio is 1.3 GB; cameras add several GB an hour.
    recording_bytes: int = _bound(4 * GIB, "--max-recording-bytes", "bytes", "one recording's file")
    record_dir_bytes: int = _bound(16 * GIB, "--max-record-dir-bytes", "bytes",
                                   "the files of one --record-dir together, recordings being written included")
    recordings: int = _bound(4, "--max-recordings", "recordings", "recordings running at once")
    recording_seconds: int = _bound(4 * 3600, "--max-recording-seconds", "seconds",
                                    "one recording's runtime seconds (a recording until Stop ends there)")

    @staticmethod
    def flag(name: str) -> str:
        """The gateway flag that sets the bound *name*."""
        return _FIELDS[name].flag

    @staticmethod
    def unit(name: str) -> str:
        """What the bound *name* counts (``bytes``, ``frames``, ``clients``)."""
        return _FIELDS[name].unit

    @staticmethod
    def doc(name: str) -> str:
        """What the bound *name* bounds, in a few words."""
        return _FIELDS[name].help

    @staticmethod
    def names() -> list[BoundName]:
        """Every bound, in declaration order."""
        return list(_NAMES)

    def over(self, name: BoundName, what: str, asked: int) -> OverBudget:
        """The refusal of *what*, which needs *asked* against the bound *name*."""
        return OverBudget(what, asked, getattr(self, name), self.flag(name), self.unit(name))

    def check(self, name: BoundName, what: str, asked: int) -> None:
        """Refuse *what* when it needs more than the bound *name*.

        Raises:
            OverBudget: naming the bound and its flag.
        """
        if asked > getattr(self, name):
            raise self.over(name, what, asked)


_FIELDS = {field.name: declared for field, declared in declared_settings(Budgets)}
_NAMES: tuple[BoundName, ...] = typing.get_args(BoundName)
if list(_NAMES) != list(_FIELDS):  # (at import: a bound added to one and not the other is a bug)
    raise TypeError(f"BoundName names the fields of Budgets in their order: {list(_FIELDS)}, not {list(_NAMES)}")


class OverBudget(Exception):
    """A resource refused because it would pass a bound; the message names the bound and its flag.

    Components turn it into their own exception (``::capture::ERROR_SEQUENCE_ENOMEM``,
    ``::bass::e_nomem``...); one that reaches the gateway is 429 ``::genomix::over_budget``.

    Attributes:
        what: What was asked for, in words.
        asked: How much it needs.
        limit: The bound.
        flag: The gateway flag that changes it.
        unit: What the numbers count.
        held: How much was already held against a bound in all (0 for a bound on one thing).
    """

    def __init__(self, what: str, asked: int, limit: int, flag: str, unit: str = "bytes", held: int = 0) -> None:
        self.what, self.asked, self.limit, self.flag, self.unit, self.held = what, asked, limit, flag, unit, held
        if held:
            message = (f"{what} needs {size_text(asked, unit)}, and {size_text(held, unit)} of the "
                       f"{size_text(limit, unit)} of {flag} are held")
        else:
            message = f"{what} needs {size_text(asked, unit)}, more than the {size_text(limit, unit)} of {flag}"
        super().__init__(message)


class Reservation:
    """An amount held against a :class:`Ledger`; give it back with :meth:`release` (or by leaving ``with``)."""

    __slots__ = ("ledger", "amount", "holder", "evict")

    def __init__(self, ledger: Ledger, amount: int, holder: str, evict: Callable[[], None] | None) -> None:
        self.ledger, self.amount, self.holder, self.evict = ledger, amount, holder, evict

    def release(self) -> None:
        """Give the amount back (idempotent)."""
        self.ledger._release(self)

    def progressed(self) -> None:
        """Say that the holder made progress (a client drained part of its reply): evicted after those that did not."""
        self.ledger._progressed(self)

    def resize(self, amount: int, what: str) -> None:
        """Hold *amount* instead (*what* names it in a refusal); growing must fit, shrinking always does.

        Raises:
            OverBudget: when the growth does not fit (the reservation is left as it was).
        """
        self.ledger._resize(self, amount, what)

    def __enter__(self) -> Reservation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


class Ledger:
    """What the components of one host hold against one bound in all.

    Args:
        name: The bound (a field of :class:`Budgets`).
        limit: Its value.
        flag: The gateway flag that changes it.
        unit: What the amounts count.
    """

    def __init__(self, name: str, limit: int, flag: str, unit: str = "bytes") -> None:
        self.name, self.limit, self.flag, self.unit = name, limit, flag, unit
        # Insertion order is the time since the last progress (a reservation that progresses moves to
        # the end): eviction takes the first, the one that has waited longest.
        self._held: dict[Reservation, None] = {}
        self.held = 0
        #: Reservations taken back to make room for others since the start.
        self.evictions = 0

    def reserve(self, amount: int, holder: str, what: str, *, evict: Callable[[], None] | None = None) -> Reservation:
        """Hold *amount* for *holder*; *what* names it in a refusal.

        Args:
            amount: How much.
            holder: Who holds it (an instance, a client), for the refusal and the log.
            what: What it is, in words (``a port of 400 chunks of 19200 frames``).
            evict: When given, the reservation may be taken back to make room for a newer one
                (those that waited longest since they were made or last :meth:`~Reservation.progressed`
                first): ``evict()`` is called (after the reservation is released) and must let go of
                what it held.

        Raises:
            OverBudget: when *amount* does not fit, even after evicting what may be evicted.
        """
        if amount > self.limit:
            raise OverBudget(what, amount, self.limit, self.flag, self.unit)
        if self.held + amount > self.limit:
            for victim in [r for r in self._held if r.evict is not None]:
                self._release(victim)
                self.evictions += 1
                assert victim.evict is not None
                victim.evict()
                if self.held + amount <= self.limit:
                    break
        if self.held + amount > self.limit:
            raise OverBudget(what, amount, self.limit, self.flag, self.unit, held=self.held)
        reservation = Reservation(self, amount, holder, evict)
        self._held[reservation] = None
        self.held += amount
        return reservation

    def _resize(self, reservation: Reservation, amount: int, what: str) -> None:
        if reservation not in self._held:
            raise ValueError(f"{reservation.holder}'s reservation was released")
        growth = amount - reservation.amount
        if growth > 0 and (amount > self.limit or self.held + growth > self.limit):
            raise OverBudget(what, amount, self.limit, self.flag, self.unit, held=self.held - reservation.amount)
        reservation.amount = amount
        self.held += growth

    def _progressed(self, reservation: Reservation) -> None:
        if reservation in self._held:
            del self._held[reservation]
            self._held[reservation] = None

    def _release(self, reservation: Reservation) -> None:
        if reservation in self._held:
            del self._held[reservation]
            self.held -= reservation.amount

    def holders(self) -> list[tuple[str, int]]:
        """Who holds how much, the longest without progress first."""
        return [(r.holder, r.amount) for r in self._held]


class Ledgers:
    """The ledgers of the bounds in all of one host (``host.ledgers``).

    Attributes:
        audio: Audio ports and ``basc`` blocks (``audio_bytes``).
        sockets: Unsent replies of the dedicated sockets (``socket_bytes``).
        render: The render processes of the worlds (``render_bytes``).
        recordings: The recordings running (``recordings``), one each.
    """

    def __init__(self, budgets: Budgets) -> None:
        self.audio = Ledger("audio_bytes", budgets.audio_bytes, budgets.flag("audio_bytes"))
        self.sockets = Ledger("socket_bytes", budgets.socket_bytes, budgets.flag("socket_bytes"))
        self.render = Ledger("render_bytes", budgets.render_bytes, budgets.flag("render_bytes"))
        self.recordings = Ledger("recordings", budgets.recordings, budgets.flag("recordings"), "recordings")
