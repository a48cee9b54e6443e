"""Finding components of other processes on Zenoh, following their hosts, and noticing when they go and return.

A :class:`ZenohDirectory` is a host's :class:`~aiogenomix.components.core.runtime.RemoteFinder`: ``load``
asks it first, and it decides where a name runs.  A gateway's follows every offer (liveliness tokens)
and every host's heartbeat; a component host's only the offers of the names it looks for and the
heartbeats of the hosts it reads from, so that what a host hears does not grow with the number of
hosts (decision 38).  Either says in its hear token how often it needs a beat, four times within its
stale bound, and hosts beat that often (every 0.5 s for the default bound of 2 s; decision 46).  A token
that disappears (the process died, or the network was cut longer than Zenoh's lease) makes the proxy of
that instance end its requests and unload; until the same host offers the instance again, its name is
refused as gone (503), then the gateway loads it again under the same name and tells every session (an
``offered`` event).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import math
import time
from collections.abc import Callable, Collection
from typing import Any

import zenoh

from ..components.core import ComponentHost, LoadError
from ..components.core.runtime import LoadedInstance, NoSuchModule, RemoteHostGone, RemoteUnreachable, names_hint
from ._links import LINK_GRACE, report_unlinked, unlinked
from ._offers import OfferBook, OfferedBefore, split_name
from ._proxy import RemoteInstance, RemoteLink, RemoteTimeouts, describe_remote, heard_text, utc_text
from ._session import Unanswered, ZenohSettings, alive, ask, connect_endpoints, on_zenoh_thread, open_session
from ._wire import (
    BEATS, LEGACY_OFFERS, OFFERS, OfferKey, beat_key, facts_key, gateway_token, hear_token, legacy_offer, offers_of,
    parse_offer,
)

__all__ = ["ZenohDirectory"]

log = logging.getLogger(__name__)

#: What a gateway tells its sessions when an instance is offered: ``{"name", "host", "loaded"}``.
OfferedListener = Callable[[dict[str, Any]], None]


class ZenohDirectory:
    """Finds remote components for a host, follows the offers and heartbeats, re-attaches what returns.

    Use :meth:`open` to create one; :meth:`aclose` closes its session.

    Args:
        session: An open Zenoh session (owned by the directory from now on).
        config: Its configuration.
        timeouts: The bounds of queries, of waiting for a name to be offered again, and of silence.
        local: The component names a load may run in this process (``--local``); every other name
            runs where a component host offers it, or nowhere.
        gateway: Whether this process sends requests: it then declares its liveliness token (the
            hosts stop its motions when it vanishes) and announces offers to *on_offered*.
        on_offered: Told of every instance offered from now on (``loaded``: the name under which
            this gateway loaded it again, when it had lost it with its host).
    """

    def __init__(self, session: zenoh.Session, config: zenoh.Config, timeouts: RemoteTimeouts | None = None,
                 local: Collection[str] = (), gateway: bool = True, on_offered: OfferedListener | None = None) -> None:
        self.session = session
        self.config = config
        self.zid = str(session.zid())
        self.timeouts = timeouts or RemoteTimeouts()
        self.on_offered = on_offered
        self._local = frozenset(local)
        self._gateway = gateway
        self._loop = asyncio.get_running_loop()
        self._opened = self._loop.time()
        self._book = OfferBook()
        self._change: asyncio.Future[None] = self._loop.create_future()
        #: When each host run (by session id) was last heard from; set on Zenoh's thread.
        self._heard: dict[str, float] = {}
        self._proxies: dict[str, RemoteInstance] = {}
        #: The instances lost with their host, by (host id, instance): re-attached when offered again.
        self._lost: dict[tuple[str, str], str] = {}
        #: The same, by name here: the host id and when it was last heard from (epoch s), for their refusals.
        self._gone: dict[str, tuple[str, float]] = {}
        self._host: ComponentHost | None = None
        self._tasks: set[asyncio.Task[Any]] = set()
        self.link = RemoteLink(session, self.zid, self.timeouts, self.silence)
        self._declared: list[Any] = []
        #: What a host's directory follows, declared as it needs it: the offers of each instance name it
        #: looked for, and the heartbeat of each host run it holds a proxy of.
        self._names: dict[str, list[Any]] = {}
        self._beats: dict[str, Any] = {}
        self._hear_token: Any = None
        if gateway:
            # A gateway hears every host (``/`` says when each was heard) and every offer; a host hears only
            # the hosts it reads from (see _follow_name and _follow_beats): with N hosts, N beats reach each
            # gateway, and none reach a host that reads no other host's port, not N - 1.
            self._declared.append(session.declare_subscriber(BEATS, on_zenoh_thread(self._on_beat)))
            self._declare_hear_token()
            for key in (OFFERS, LEGACY_OFFERS):
                self._declared.append(self._offers_subscriber(key))
            # Declared before any request is sent: a host that runs our motions sees us vanish.
            self._declared.append(session.liveliness().declare_token(gateway_token(self.zid)))
        # Zenoh retries an endpoint that refuses us without a word: say it once, and why.
        self._spawn(report_unlinked(session, config), "zenoh links")

    @classmethod
    async def open(cls, settings: ZenohSettings, timeouts: RemoteTimeouts | None = None, *,
                   local: Collection[str] = (), gateway: bool = True,
                   on_offered: OfferedListener | None = None) -> ZenohDirectory:
        """Open a Zenoh session with *settings* and a directory on it.

        Raises:
            ZenohSessionError: when the session cannot be opened.
        """
        session, config = await asyncio.to_thread(open_session, settings)
        return cls(session, config, timeouts, local, gateway, on_offered)

    # -- the finder ----------------------------------------------------------------------------

    def may_run_here(self, name: str) -> bool:
        """Whether a load of *name* may run it in this process (it was named with ``--local``)."""
        return name in self._local

    def offered(self) -> list[str]:
        """The instances component hosts offer now, each once."""
        return self._book.names()

    async def find(self, host: ComponentHost, name: str, argv: list[str]) -> LoadedInstance | None:
        """The proxy of what *name* designates (``demo``, ``demo@robot1``); None for a name that runs here.

        A name a host offered and no longer offers is waited for up to the control timeout: a
        host that restarts is never replaced by anything else.

        Raises:
            NoSuchModule: when no host offers *name* (and it may not run here).
            AmbiguousModule: when several hosts offer it: the message names each, to load as NAME@HOST.
            LoadError: for load options other than ``-i`` (a remote instance is configured where it
                runs), or an instance name taken here.
            RemoteUnreachable: when the host that offered it does not offer it again in time, or
                does not answer.
        """
        instance, host_id = split_name(name)
        if host_id is None and name in self._local:
            return None
        self._follow(host)
        self._follow_name(instance)
        local_name = _local_name(instance, argv)
        existing = host.instances.get(local_name)
        if (isinstance(existing, RemoteInstance) and existing.remote_instance == instance
                and host_id in (None, existing.offer.host)):
            return existing
        # What the load's reply (or its refusal) says of each host that offers it: its endpoints.
        await asyncio.gather(*(self._ask_facts(o.zid) for o in self._book.offers_of(instance, host_id)
                               if not self._book.facts(o.zid)))
        deadline = self._loop.time() + self.timeouts.control
        while True:
            offer = await self._resolve(name, instance, host_id, deadline)
            if offer is None:
                if host.knows(instance):
                    raise NoSuchModule(f"no component host offers {instance}; to run {instance} in this gateway, "
                                       f"start the gateway with --local {instance}")
                raise NoSuchModule(f"no component {instance!r} {names_hint(instance, host.available(), 'available')}")
            if existing is not None:
                where = existing.placement()
                place = ("this gateway" if where.get("runs") == "here"
                         else f"{where.get('instance')}@{where.get('host')}")
                raise LoadError(f"instance name {local_name!r} is taken by {place}: load {name} with -i "
                                f"ANOTHER_NAME")
            host.check_room()
            if not self._book.facts(offer.zid):
                await self._ask_facts(offer.zid)  # heard of while the load waited: where it runs, said at once
            try:
                description = await describe_remote(self.session, offer, self.timeouts.control)
                break
            except Unanswered as exc:
                # The host withdrew it (or went away) as it was asked: the token's removal is on its way.
                # Once it is heard, the name is one offered before: waited for as any restarting host's.
                await self._withdrawn(offer, deadline, exc)
        self._follow_beats(offer.zid)
        proxy = RemoteInstance(host, self.link, offer, local_name, description,
                               lambda: self._book.facts(offer.zid))
        try:
            await proxy.start()
        except BaseException:
            await proxy.stop()  # what it declared goes with it (it sent nothing: nothing to let go of)
            raise
        return proxy  # the host lists it (or stops it, when a concurrent load won): see _attached

    async def _resolve(self, name: str, instance: str, host_id: str | None, deadline: float) -> OfferKey | None:
        """The offer *name* designates, waiting until *deadline* for a host that offered it to offer it again."""
        asked = False
        while True:
            try:
                offer = self._book.resolve(name)
            except OfferedBefore as before:
                left = deadline - self._loop.time()
                if left <= 0:
                    raise RemoteUnreachable(
                        f"{name} was offered by {', '.join(before.hosts)}, which has not offered it again within "
                        f"{self.timeouts.control:g} s: the host is down, restarting or cut off (nothing else "
                        f"runs it in its place)") from None
                await self._next_change(left)
                continue
            except NoSuchModule:
                if asked:
                    raise
                offer = None
            if offer is not None or asked:
                return offer
            # Not heard of yet: ask the network now (a gateway that has just started, a host that has just
            # come), then decide with what it says.
            asked = True
            await self._first_links(deadline)
            pattern = f"aiogenomix/offer/*/{host_id or '*'}/*/{instance}"
            for key in await alive(self.session, pattern, timeout=min(2.0, self.timeouts.control)):
                self._take_offer(key, present=True)

    async def _first_links(self, deadline: float) -> None:
        """In a session's first seconds, wait for its links to the endpoints it connects to (up to *deadline*).

        A name asked of a network not reached yet is not a name nobody offers: a load sent as soon as
        the gateway listens would otherwise be refused while Zenoh is still linking (seconds on a busy
        machine).  Later, an endpoint with no link is down or refuses us, and ``report_unlinked`` says so.
        """
        endpoints = connect_endpoints(self.config)
        until = min(deadline, self._opened + LINK_GRACE)
        # Zenoh raises no event when a link comes up: looked at every 50 ms, only in these first seconds.
        while self._loop.time() < until:
            if not await asyncio.to_thread(unlinked, self.session, endpoints):
                return
            await asyncio.sleep(0.05)

    async def _withdrawn(self, offer: OfferKey, deadline: float, unanswered: Unanswered) -> None:
        """Wait until *offer*, whose host no longer answers for it, is heard withdrawn (or until *deadline*).

        Raises:
            RemoteUnreachable: when the offer still stands at *deadline*: its host keeps the token but
                answers nothing for it.
        """
        while offer.key in {o.key for o in self._book.offers_of(offer.instance)}:
            left = deadline - self._loop.time()
            if left <= 0:
                raise RemoteUnreachable(
                    f"{offer.name} is still offered, but nothing answered for it within {self.timeouts.control:g} s "
                    f"({unanswered}): its host is withdrawing it or going away") from None
            await self._next_change(left)

    async def _next_change(self, within: float) -> None:
        await asyncio.wait({self._change}, timeout=within)

    def _follow(self, host: ComponentHost) -> None:
        if self._host is None:
            self._host = host
            host.add_load_listener(self._attached)
            host.add_unload_listener(self._forget)

    def _attached(self, instance: LoadedInstance) -> None:
        """A proxy of ours is listed by the host: follow its host's offer from now on."""
        if not isinstance(instance, RemoteInstance) or instance.link is not self.link:
            return
        offer = instance.offer
        self._proxies[instance.instance] = instance
        self._lost.pop((offer.host, offer.instance), None)
        self._gone.pop(instance.instance, None)
        if offer.key not in {o.key for o in self._book.offers_of(offer.instance)}:
            # Withdrawn while it started: lost at once, as if heard now.
            self._lose(instance)

    def _lose(self, proxy: RemoteInstance) -> None:
        """*proxy*'s host withdrew its instance or is gone: end what waits on it, unload it, say so until it returns."""
        offer = proxy.offer
        self._lost[(offer.host, offer.instance)] = proxy.instance
        proxy.lost(f"{proxy.instance} ran on component host {offer.host}, which stopped or cannot be reached "
                   f"({proxy.last_heard()})")
        self._gone[proxy.instance] = (offer.host, proxy.heard_at())

    def absent(self, instance: str) -> RemoteHostGone | None:
        """Why *instance* is not loaded, when it was lost with its host (None: this directory knows nothing of it)."""
        gone = self._gone.get(instance)
        if gone is None:
            return None
        host, heard_at = gone
        return RemoteHostGone(f"{instance} ran on component host {host}, which stopped or cannot be reached "
                              f"({heard_text(heard_at)}); it is loaded again when {host} offers it again", host,
                              utc_text(heard_at))

    def _forget(self, instance: str) -> None:
        proxy = self._proxies.get(instance)
        if proxy is not None and self._host is not None and self._host.instances.get(instance) is not proxy:
            del self._proxies[instance]

    # -- what is heard -------------------------------------------------------------------------

    def silence(self, zid: str) -> float:
        """Seconds since the host of session *zid* was heard from (infinite: never)."""
        heard = self._heard.get(zid)
        return math.inf if heard is None else time.monotonic() - heard

    def _offers_subscriber(self, key: str) -> Any:
        # With history: the tokens already declared come first, then every change.
        return self.session.liveliness().declare_subscriber(key, on_zenoh_thread(self._on_offer), history=True)

    def _follow_name(self, instance: str) -> None:
        """Follow the offers of *instance* from now on (a host's directory follows the names it looks for)."""
        if self._gateway or instance in self._names:
            return
        self._names[instance] = [self._offers_subscriber(offers_of(instance)),
                                 self._offers_subscriber(legacy_offer(instance))]

    def _follow_beats(self, zid: str) -> None:
        """Hear the heartbeat of the host run *zid* (a gateway hears every host's already)."""
        if self._gateway or zid in self._beats:
            return
        self._declare_hear_token()
        self._beats[zid] = self.session.declare_subscriber(beat_key(zid), on_zenoh_thread(self._on_beat))

    def _declare_hear_token(self) -> None:
        """Tell hosts how often this process needs their beat (once; it stands until the session closes)."""
        if self._hear_token is None:
            self._hear_token = self.session.liveliness().declare_token(hear_token(self.zid, self.timeouts.stale))
            self._declared.append(self._hear_token)

    def _run_over(self, zid: str) -> None:
        """The host run *zid* offers nothing any more: stop hearing it."""
        self._heard.pop(zid, None)
        beats = self._beats.pop(zid, None)
        if beats is not None:
            with contextlib.suppress(zenoh.ZError):
                beats.undeclare()

    def _on_beat(self, sample: zenoh.Sample) -> None:
        # On Zenoh's thread, whatever the event loop is doing: a busy gateway does not make a host stale.
        self._heard[str(sample.key_expr).split("/")[2]] = time.monotonic()

    def _on_offer(self, sample: zenoh.Sample) -> None:
        key, present = str(sample.key_expr), sample.kind != zenoh.SampleKind.DELETE
        self._loop.call_soon_threadsafe(self._take_offer, key, present)

    def _take_offer(self, key: str, present: bool) -> None:
        offer = parse_offer(key)
        if offer is None:
            return
        if present:
            if key in {o.key for o in self._book.offers_of(offer.instance)}:
                return  # heard twice (history and a direct question)
            if not self._book.add(offer):
                log.warning("refused the offer %s: it is of remote protocol %d", key, offer.protocol)
            else:
                if self._gateway and not self._book.facts(offer.zid):
                    # For `/` (a host's directory asks when it loads: see find).
                    self._spawn(self._ask_facts(offer.zid), f"facts of {offer.host}")
                self._spawn(self._offered(offer), f"offered {offer.name}")
        else:
            gone = self._book.remove(key)
            for proxy in list(self._proxies.values()):
                if gone is not None and proxy.offer == gone:
                    log.warning("%s is gone: its component host %s stopped or cannot be reached (%s)",
                                proxy.instance, gone.host, proxy.last_heard())
                    self._lose(proxy)
            if gone is not None and not self._book.offers_by(gone.zid):
                self._run_over(gone.zid)
        self._change.set_result(None)
        self._change = self._loop.create_future()

    async def _ask_facts(self, zid: str) -> None:
        try:
            facts = await ask(self.session, facts_key(zid), None, self.timeouts.control,
                              what=f"the facts of host session {zid}")
        except RemoteUnreachable as exc:
            log.info("no facts from host session %s: %s", zid, exc)
            return
        if isinstance(facts, dict):
            self._book.set_facts(zid, facts)

    async def _offered(self, offer: OfferKey) -> None:
        """Load again what was lost with its host, then tell every session of the offer."""
        if not self._gateway:
            return
        loaded = None
        name = self._lost.pop((offer.host, offer.instance), None)
        lost = None if name is None else self._proxies.get(name)
        if name is not None and lost is not None and self._host is not None and self._host.instances.get(name) is lost:
            # Its unload (under way since it was lost) ends first: the name is free for the new run.
            with contextlib.suppress(NoSuchModule):
                await self._host.unload(name)
        if name is not None and self._host is not None and name not in self._host.instances:
            try:
                loaded = (await self._host.load(offer.name, ["-i", name])).instance
                log.info("%s is offered again by %s: loaded again as %s", offer.instance, offer.host, loaded)
            except Exception as exc:  # noqa: BLE001  # said in the log; the offered event says it was not loaded
                log.warning("%s is offered again by %s, but could not be loaded again: %s", offer.instance,
                            offer.host, exc)
        if name is not None:
            self._gone.pop(name, None)  # loaded again, or not to be: no longer waiting for its host
        if self.on_offered is not None:
            self.on_offered({"name": offer.instance, "host": offer.host, "loaded": loaded})

    def _spawn(self, work: Any, name: str) -> None:
        task = self._loop.create_task(work, name=name)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- what / shows ----------------------------------------------------------------------------

    def view(self) -> dict[str, Any]:
        """This session, its links, the hosts heard (with how long ago), and the offers refused."""
        hosts = self._book.hosts()
        for run in hosts:
            silence = self.silence(run["zid"])
            run["heard"] = None if math.isinf(silence) else round(silence, 3)
        return {"zid": self.zid, "links": sorted(str(link.dst) for link in self.session.info.links()),
                "hosts": hosts, "refused": self._book.refused()}

    async def aclose(self) -> None:
        """Close the session (the proxies were unloaded by the host first)."""
        for task in list(self._tasks):
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        for declared in [*self._declared, *(s for pair in self._names.values() for s in pair), *self._beats.values()]:
            with contextlib.suppress(zenoh.ZError):
                declared.undeclare()
        await asyncio.to_thread(self.session.close)


def _local_name(instance: str, argv: list[str]) -> str:
    """The instance name here: *instance*, or the ``-i NAME`` of *argv*.

    Raises:
        LoadError: for any other option (a remote instance is configured where it runs).
    """
    if not argv:
        return instance
    if len(argv) == 2 and argv[0] == "-i":
        if not argv[1].isidentifier():
            raise LoadError("-i needs an instance name made of letters, digits and _")
        return argv[1]
    raise LoadError(f"{instance} runs in another process: its options are given to aiogenomix-component there "
                    f"(here only -i NAME, the name it has in this gateway)")
