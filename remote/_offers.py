"""What component hosts offer, as a gateway hears it, and which offer a load name designates (sans I/O).

An offer is an instance one host offers (``demo`` on ``robot1``).  A load names an instance
(``demo``: whichever host offers it, when only one does) or an instance on a host (``demo@robot1``).
A name two hosts offer is never guessed: the load is refused, naming both.  A name a host offered
and no longer does is waited for, never replaced by something else (see ``ZenohDirectory.find``).
"""

from __future__ import annotations

from typing import Any

from ..components.core.runtime import AmbiguousModule, NoSuchModule, RemoteRefusal
from ._wire import PROTOCOL, OfferKey, host_id_error

__all__ = ["OfferBook", "OfferedBefore", "split_name"]


class OfferedBefore(LookupError):
    """No host offers the name now, but some did: it may come back (a host that restarts).

    Args:
        hosts: The ids of the hosts that offered it.
    """

    def __init__(self, name: str, hosts: list[str]) -> None:
        super().__init__(f"{name} was offered by {', '.join(hosts)}")
        self.hosts = hosts


def split_name(name: str) -> tuple[str, str | None]:
    """``demo@robot1`` as ``("demo", "robot1")``; ``demo`` as ``("demo", None)``.

    Both parts become chunks of Zenoh keys: an instance is an identifier, a host a host id
    (:func:`~aiogenomix.remote._wire.host_id_error`), never a wildcard or a separator.

    Raises:
        NoSuchModule: for a name that is neither.
    """
    instance, at, host = name.partition("@")
    if not instance.isidentifier() or (at and host_id_error(host) is not None):
        shown = ascii(name if len(name) <= 60 else name[:57] + "...")
        raise NoSuchModule(f"{shown} is not a load name: write INSTANCE or INSTANCE@HOST (demo@robot1), an "
                           f"instance of letters, digits and _, a host of letters, digits, '.', '_' and '-'")
    return instance, host if at else None


class OfferBook:
    """The offers heard now, the hosts' facts, the offers refused, and the names offered before."""

    def __init__(self) -> None:
        self._offers: dict[str, OfferKey] = {}
        self._refused: dict[str, OfferKey] = {}
        self._facts: dict[str, dict[str, Any]] = {}
        #: The hosts that ever offered each instance (a load of it waits for them, never runs elsewhere).
        self._seen: dict[str, set[str]] = {}

    # -- what is heard -----------------------------------------------------------------------

    def add(self, offer: OfferKey) -> bool:
        """Take an offer heard; return whether it is one this gateway can use (same protocol)."""
        if offer.protocol != PROTOCOL:
            self._refused[offer.key] = offer
            return False
        self._offers[offer.key] = offer
        self._seen.setdefault(offer.instance, set()).add(offer.host)
        return True

    def remove(self, key: str) -> OfferKey | None:
        """Forget the offer of token *key* (withdrawn, or its host gone); return it if it was usable."""
        self._refused.pop(key, None)
        offer = self._offers.pop(key, None)
        if offer is not None and not any(o.zid == offer.zid for o in self._offers.values()):
            self._facts.pop(offer.zid, None)  # that run of the host is over
        return offer

    def set_facts(self, zid: str, facts: dict[str, Any]) -> None:
        """What the host of session *zid* says of itself (kept while it offers something)."""
        if any(o.zid == zid for o in self._offers.values()):
            self._facts[zid] = facts

    def facts(self, zid: str) -> dict[str, Any]:
        """What the host of session *zid* said of itself (empty until it answered)."""
        return self._facts.get(zid, {})

    # -- what a load finds -------------------------------------------------------------------

    def names(self) -> list[str]:
        """The instances offered now, each once, whoever offers them."""
        return sorted({offer.instance for offer in self._offers.values()})

    def offers_by(self, zid: str) -> list[OfferKey]:
        """The offers of the host run *zid* now."""
        return [o for o in self._offers.values() if o.zid == zid]

    def offers_of(self, instance: str, host: str | None = None) -> list[OfferKey]:
        """The offers of *instance* now (by *host* only, when given), in a stable order."""
        return sorted((o for o in self._offers.values() if o.instance == instance and host in (None, o.host)),
                      key=lambda o: (o.host, o.zid))

    def resolve(self, name: str) -> OfferKey | None:
        """The one offer *name* designates now; None when nobody offers it now nor did before.

        Raises:
            AmbiguousModule: when two hosts offer it (or two hosts share the host id named).
            OfferedBefore: when nobody offers it now but a host did.
            NoSuchModule: for a host that never offered the instance named with it.
            RemoteRefusal: when only a host of another protocol version offers it.
        """
        instance, host = split_name(name)
        offers = self.offers_of(instance, host)
        if len(offers) == 1:
            return offers[0]
        if len(offers) > 1:
            if host is None:
                hosts = [f"{o.host} ({self._where(o)})" for o in offers]
                loads = " or ".join(o.name for o in offers)
                raise AmbiguousModule(f"{instance} is offered by {len(offers)} component hosts, "
                                      f"{', '.join(hosts)}: load {loads}")
            sessions = [f"session {o.zid} ({self._where(o)})" for o in offers]
            raise AmbiguousModule(f"{len(offers)} component hosts call themselves {host} and offer {instance}: "
                                  f"{', '.join(sessions)}; give each its own --host-id")
        seen = self._seen.get(instance, set())
        before = sorted(seen if host is None else seen & {host})
        if before:
            raise OfferedBefore(name, before)
        refused = [o for o in self._refused.values() if o.instance == instance]
        if refused:
            protocols = sorted({o.protocol for o in refused})
            message = (f"{instance} is offered by a component host of remote protocol "
                       f"{', '.join(map(str, protocols))}; this gateway speaks protocol {PROTOCOL}: run the same "
                       f"aiogenomix release on both")
            raise RemoteRefusal(502, {"ex": "::genomix::remote_protocol", "message": message})
        if host is not None:
            offered = ", ".join(o.name for o in self._offers.values() if o.host == host) or "nothing"
            raise NoSuchModule(f"component host {host} does not offer {instance} (it offers {offered})")
        return None

    def _where(self, offer: OfferKey) -> str:
        return ", ".join(self.facts(offer.zid).get("endpoints") or []) or f"session {offer.zid}"

    # -- what / shows --------------------------------------------------------------------------

    def hosts(self) -> list[dict[str, Any]]:
        """Each host run heard now: its id, session, protocol, endpoints and offers."""
        runs: dict[str, dict[str, Any]] = {}
        for offer in sorted(self._offers.values(), key=lambda o: (o.host, o.zid, o.instance)):
            facts = self.facts(offer.zid)
            run = runs.setdefault(offer.zid, {
                "host": offer.host, "zid": offer.zid, "protocol": offer.protocol,
                "aiogenomix": facts.get("aiogenomix"), "endpoints": facts.get("endpoints", []),
                "audio_socket": facts.get("audio_socket"), "offers": {}})
            described = facts.get("instances", {}).get(offer.instance, {})
            run["offers"][offer.instance] = {"component": described.get("component"),
                                             "version": described.get("version")}
        return list(runs.values())

    def refused(self) -> list[dict[str, Any]]:
        """The offers of hosts of another protocol version, refused."""
        return [{"key": o.key, "protocol": o.protocol,
                 "why": f"remote protocol {o.protocol}; this gateway speaks {PROTOCOL}"}
                for o in sorted(self._refused.values(), key=lambda o: o.key)]
