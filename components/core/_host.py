"""The component host: which components can be loaded, the loaded instances, the shared clock and rig.

The gateway owns one host; tests and scripts can use one directly.  Loadable
components are the ``aiogenomix.components`` entry points (plus any factory
registered explicitly) — never an arbitrary path.  Components that meet on
one host find each other's capabilities by type (:meth:`ComponentHost.provide`,
:meth:`ComponentHost.find`), never by a component's name.
"""

from __future__ import annotations

import asyncio
import contextlib
import contextvars
import importlib.metadata
import logging
from collections.abc import Callable
from typing import Any, Protocol, TypeVar, overload

from ._budgets import Ledgers
from ._clock import Clock, RealClock
from ._component import Component
from ._events import HostEvents, InstanceLoaded, InstanceUnloaded, SessionEnded
from ._exceptions import ComponentError, NoSuchModule, names_hint
from ._instance import LoadedInstance
from ._log_limits import ThrottledLog
from ._requests import RequestStatus
from ._settings import HostSettings

__all__ = ["ComponentHost", "LoadError", "TooManyInstances", "RemoteFinder", "NoCapability"]

T = TypeVar("T")

log = logging.getLogger(__name__)
#: Loads are asked for by clients: a client loading and unloading in a loop must not fill the log.
_client_log = ThrottledLog(log)

ENTRY_POINT_GROUP = "aiogenomix.components"

#: The (host, task) loading a component right now: a component whose ``on_start`` loads another
#: (``pr2`` loads ``world``) runs inside its own load, under the host's lock already.
_LOADING: contextvars.ContextVar[tuple[object, object] | None] = contextvars.ContextVar("aiogenomix_loading",
                                                                                         default=None)


class LoadError(ComponentError, ValueError):
    """Bad load arguments (unknown option, instance name taken, ...)."""


class TooManyInstances(ComponentError):
    """The host already runs as many instances as it may."""


class NoCapability(ComponentError, LookupError):
    """No component of the host provides the capability asked for."""


class RemoteFinder(Protocol):
    """Finds components that run in other processes and gives a local proxy of them.

    A host with a finder (``host.finder``) asks it first for every name it loads: the finder
    answers with the proxy of an instance another process offers (which the gateway serves like
    any instance, see ``aiogenomix.remote``), refuses the name, or says that it runs in this
    process.  The finder decides, so that no race with a host that restarts can change where a
    robot's commands go.
    """

    async def find(self, host: ComponentHost, name: str, argv: list[str]) -> LoadedInstance | None:
        """The started proxy that *name* designates (the one loaded already, if any); None: it runs here.

        A new proxy is made only after ``host.check_room()``.  It is called without the host's
        lock (it may wait for the network): the host lists the proxy it returns, or stops it when a
        concurrent load listed the name first.

        Raises:
            NoSuchModule: when no process offers *name* and it may not run here.
            AmbiguousModule: when several processes offer *name*.
            LoadError: for load options a remote instance does not take, or an instance name taken.
            RemoteUnreachable: when the process that offers it does not answer.
        """

    def offered(self) -> list[str]:
        """The names other processes offer now and a load may name, as far as this finder knows."""

    def may_run_here(self, name: str) -> bool:
        """Whether a load of the component *name* may run it in this process."""

    def view(self) -> dict[str, Any]:
        """What this finder knows, for ``/``: the hosts it hears (where each runs, what each offers)."""

    def absent(self, instance: str) -> ComponentError | None:
        """Why *instance*, which is not loaded here, is not, when the finder knows (its host is gone); else None."""


class ComponentHost:
    """Loads, runs and unloads component instances.

    Args:
        clock: The clock of every component (default: real time).
        settings: The rig the components drive (default: every setting's default, a simulated rig).
        factories: Loadable components by name; default: the installed entry points.
        function_grace: How long a send waits for a function to end before replying ``sent``.
        max_instances: How many instances may be loaded at once (each runs tasks and may hold hardware).
    """

    def __init__(self, clock: Clock | None = None, settings: HostSettings | None = None,
                 factories: dict[str, Callable[..., Component]] | None = None,
                 function_grace: float = 2.0, max_instances: int = 64) -> None:
        self.clock = clock or RealClock()
        #: What happens on this host, as objects: requests sent and ended, instances loaded and
        #: unloaded, sessions ended (:meth:`HostEvents.subscribe`).
        self.events = HostEvents(self.clock.wall)
        if settings is not None and not isinstance(settings, HostSettings):
            raise TypeError(f"settings are a HostSettings, not {type(settings).__name__}: "
                            "HostSettings(can=..., audio_device=...)")
        self.settings = settings or HostSettings()
        #: What the components hold against the bounds in all (``settings.budgets``).
        self.ledgers = Ledgers(self.settings.budgets)
        self.function_grace = function_grace
        self.max_instances = max_instances
        self._factories = factories if factories is not None else self._entry_points()
        self._instances: dict[str, LoadedInstance] = {}
        self._shared: dict[object, Any] = {}
        self._capabilities: dict[type, list[tuple[str, object]]] = {}
        self._request_listeners: list[Callable[[RequestStatus], None]] = []
        self._unload_listeners: list[Callable[[str], None]] = []
        self._load_listeners: list[Callable[[LoadedInstance], None]] = []
        self._background: set[asyncio.Task[Any]] = set()
        self._lock = asyncio.Lock()
        #: Where components of other processes are found (None: this process only).
        self.finder: RemoteFinder | None = None
        self._closing = False

    @staticmethod
    def _entry_points() -> dict[str, Callable[..., Component]]:
        found: dict[str, Callable[..., Component]] = {}
        for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
            found[entry.name] = _LazyFactory(entry)
        return found

    # -- what can be loaded ----------------------------------------------------------------

    def available(self) -> list[str]:
        """The names of the loadable components (with a finder: those other processes offer, those it lets run here)."""
        if self.finder is None:
            return sorted(self._factories)
        finder = self.finder
        return sorted({*finder.offered(), *(name for name in self._factories if finder.may_run_here(name))})

    def knows(self, name: str) -> bool:
        """Whether a component *name* can be made in this process (it is registered)."""
        return name in self._factories

    def register(self, name: str, factory: Callable[..., Component]) -> None:
        """Make a component class loadable under *name*."""
        self._factories[name] = factory

    def component_class(self, name: str) -> type[Component]:
        """The class of the loadable component *name*.

        Raises:
            NoSuchModule: for a name that is not registered.
        """
        factory = self._factories.get(name)
        if factory is None:
            raise NoSuchModule(f"no component {name!r} {names_hint(name, self.available(), 'available')}")
        if isinstance(factory, _LazyFactory):
            return factory.load()
        if not (isinstance(factory, type) and issubclass(factory, Component)):
            raise TypeError(f"the component {name!r} was registered as {factory!r}, not a Component class")
        return factory

    def usage(self, name: str) -> list[dict[str, str]]:
        """The load options of component *name*, as ``{"option", "descr"}`` objects."""
        return [{"option": o, "descr": d} for o, d in self.component_class(name).usage_options]

    # -- instances -------------------------------------------------------------------------

    @property
    def instances(self) -> dict[str, LoadedInstance]:
        """The loaded instances by name."""
        return dict(self._instances)

    def get(self, instance: str) -> LoadedInstance:
        """The loaded instance *instance*.

        Raises:
            NoSuchModule: when no such instance is loaded (naming the loaded ones it may be a typo of).
            RemoteHostGone: when it ran in another process whose host is gone (the finder says so).
        """
        try:
            return self._instances[instance]
        except KeyError:
            pass
        why = None if self.finder is None else self.finder.absent(instance)
        if why is not None:
            raise why
        raise NoSuchModule(f"no module {instance!r} is loaded {names_hint(instance, self._instances, 'loaded')}")

    async def load(self, name: str, argv: list[str] | None = None) -> LoadedInstance:
        """Load component *name* (``-i INSTANCE`` in *argv* picks the instance name).

        Loading a component that is already loaded under the same instance name
        returns the running instance, so clients may call ``load`` at every start.
        With a finder, the finder decides first whether *name* runs in another process.

        Raises:
            NoSuchModule: for an unknown component.
            LoadError: for bad arguments (an option the component does not list in its usage).
            TooManyInstances: when ``max_instances`` instances are loaded already.
        """
        nested = _LOADING.get() == (self, asyncio.current_task())
        if self.finder is not None:
            # What another process offers runs there, not here: it is what the user started that
            # process for.  The finder says which names may run here at all.  It waits for the
            # network (a host's facts, a host that restarts, the description): never under the
            # lock, which every unload needs.
            proxy = await self.finder.find(self, name, list(argv or []))
            if proxy is not None:
                return await self._hold(proxy, name, nested)
        # The first load imports the component's package (scipy, sound and CAN libraries):
        # up to seconds of work that must not stall the gateway's event loop.
        await asyncio.to_thread(self.component_class, name)
        args = list(argv or [])
        instance = name
        if "-i" in args:
            at = args.index("-i")
            if at + 1 >= len(args) or not args[at + 1].isidentifier():
                raise LoadError("-i needs an instance name made of letters, digits and _")
            instance = args[at + 1]
            del args[at:at + 2]
        _check_options(self.component_class(name), args)
        async with contextlib.nullcontext() if nested else self._lock:
            existing = self._instances.get(instance)
            if existing is not None:
                if existing.genom_name != self.component_class(name).genom_name:
                    raise LoadError(f"instance name {instance!r} is taken by a {existing.genom_name} component")
                return existing
            self.check_room()
            cls = self.component_class(name)
            component = cls(self, instance, args)
            token = _LOADING.set((self, asyncio.current_task()))
            try:
                await component.start()
            except BaseException:
                self.withdraw(instance)  # what it offered before failing goes with it
                raise
            finally:
                _LOADING.reset(token)
            self._instances[instance] = component
            _client_log.info("loaded %s as %s", name, instance)
            self._loaded(component)
            return component

    def check_room(self) -> None:
        """Refuse one more instance beyond ``max_instances`` (the proxy of a remote one counts too)."""
        if len(self._instances) >= self.max_instances:
            raise TooManyInstances(f"{len(self._instances)} instances are loaded, the most this gateway allows: "
                                   f"unload one first")

    async def _hold(self, proxy: LoadedInstance, name: str, nested: bool = False) -> LoadedInstance:
        """List the started *proxy* a finder gave for *name*, unless another load listed its name meanwhile.

        The finder ran outside the lock: a concurrent load of the same name may have won.  The
        loser is stopped; its winner is the answer when it runs in the same place, else the name
        is taken.

        Raises:
            LoadError: when the name was taken meanwhile by an instance running elsewhere.
            TooManyInstances: when the room went meanwhile.
        """
        full: TooManyInstances | None = None
        async with contextlib.nullcontext() if nested else self._lock:
            listed = self._instances.get(proxy.instance)
            if listed is proxy:
                return proxy
            if listed is None:
                try:
                    self.check_room()
                except TooManyInstances as exc:
                    full = exc  # the room went while the proxy started
                else:
                    self._instances[proxy.instance] = proxy
                    _client_log.info("loaded %s from another process as %s", name, proxy.instance)
                    self._loaded(proxy)
                    return proxy
        await proxy.stop()
        if full is not None:
            raise full
        if listed is not None and listed.placement() == proxy.placement():
            return listed
        raise LoadError(f"instance name {proxy.instance!r} was taken while {name} was loaded: load it with "
                        f"-i ANOTHER_NAME")

    async def peer(self, instance: str) -> LoadedInstance:
        """The instance *instance*, loaded here or, with a finder, the proxy of one in another process.

        Raises:
            NoSuchModule: when neither this host nor another process runs it.
        """
        if instance in self._instances or self.finder is None:
            return self.get(instance)
        proxy = await self.finder.find(self, instance, [])
        if proxy is None:
            raise NoSuchModule(f"no module {instance!r} is loaded here or offered by another process")
        return await self._hold(proxy, instance)

    async def unload(self, instance: str) -> None:
        """Stop and forget an instance, then tell the unload listeners.

        Raises:
            NoSuchModule: when no such instance is loaded.
        """
        async with self._lock:
            component = self.get(instance)
            del self._instances[instance]
        await component.stop()
        self.withdraw(instance)
        del component     # held here no more: a listener that collects the garbage (the settled heap's) frees it
        for listener in list(self._unload_listeners):
            listener(instance)
        self.events.publish(InstanceUnloaded(instance, self.clock.wall()))

    def unload_soon(self, instance: str) -> None:
        """Unload *instance* in the background (used by a component's own ``kill``)."""
        task = asyncio.create_task(self.unload(instance), name=f"unload {instance}")
        self._background.add(task)
        task.add_done_callback(self._background.discard)

    def end_session(self, session: str) -> None:
        """The gateway's session *session* ended: tell every instance, in the background.

        An instance whose running requests came from that session may end them
        (:meth:`Component.on_session_end <aiogenomix.components.core.Component.on_session_end>`:
        the recorder stops a recording of it); an instance of another process hears it through
        its proxy.  A failure is logged, never raised: the session is over whatever an instance does.
        The subscribers of the host's events hear :class:`SessionEnded`.
        """
        self.events.publish(SessionEnded(session, self.clock.wall()))
        task = asyncio.create_task(self._end_session(session), name=f"session {session} ended")
        self._background.add(task)
        task.add_done_callback(self._background.discard)

    async def _end_session(self, session: str) -> None:
        for name, instance in list(self._instances.items()):
            try:
                await instance.session_ended(session)
            except Exception as exc:  # noqa: BLE001  # the others are told all the same
                log.warning("%s: the end of session %r was not handled: %s: %s", name, session,
                            type(exc).__name__, exc)

    # -- shared resources and events ---------------------------------------------------------

    @overload
    def shared(self, key: type[T], factory: Callable[[], T]) -> T: ...

    @overload
    def shared(self, key: str, factory: Callable[[], Any]) -> Any: ...

    def shared(self, key: type[T] | str, factory: Callable[[], Any]) -> Any:
        """One object per host for *key* (its class), created by *factory* on first use.

        Simulated hardware lives here so that several components drive the same
        rig (``kemar`` and ``kemarcapture`` turn one simulated head).  The host
        closes it last (its ``aclose``, if it has one).  A string key is for a
        resource the host only closes (the gateway's Zenoh session).
        """
        if key not in self._shared:
            made = factory()
            if isinstance(key, type) and not isinstance(made, key):
                raise TypeError(f"the shared {key.__name__} was made as a {type(made).__name__}")
            self._shared[key] = made
        return self._shared[key]

    # -- capabilities, offered and found by type ----------------------------------------------

    def provide(self, kind: type[T], value: T, *, by: str) -> None:
        """Offer *value* as this host's *kind*, on behalf of the instance *by*.

        Components find each other this way, by what they offer, never by name:
        a simulated head provides a ``HeadAzimuth`` that a simulated sound scene
        follows, whichever component turns it.  The offer made last is found
        first; an instance's offers are withdrawn when it is unloaded.

        Raises:
            TypeError: when *value* is not a *kind*.
        """
        if not isinstance(value, kind):
            raise TypeError(f"{by} provides a {type(value).__name__} as a {kind.__name__}")
        self._capabilities.setdefault(kind, []).append((by, value))

    def find(self, kind: type[T]) -> T | None:
        """The *kind* a component of this host provides (the last offer), or None."""
        offers = self._capabilities.get(kind)
        if not offers:
            return None
        value = offers[-1][1]
        assert isinstance(value, kind)  # provide checked it
        return value

    def require(self, kind: type[T]) -> T:
        """The *kind* a component of this host provides (the last offer).

        Raises:
            NoCapability: when no loaded component provides one.
        """
        value = self.find(kind)
        if value is None:
            raise NoCapability(f"no component of this host provides a {kind.__name__}")
        return value

    def withdraw(self, by: str, kind: type | None = None) -> None:
        """Withdraw the offers of the instance *by* (of *kind* only, when given)."""
        for offered, offers in list(self._capabilities.items()):
            if kind is None or offered is kind:
                offers[:] = [(who, value) for who, value in offers if who != by]
                if not offers:
                    del self._capabilities[offered]

    def add_request_listener(self, listener: Callable[[RequestStatus], None]) -> None:
        """Call *listener* with every request whose status changed."""
        self._request_listeners.append(listener)

    def remove_request_listener(self, listener: Callable[[RequestStatus], None]) -> None:
        """Stop calling *listener* (added by :meth:`add_request_listener`; nothing if it was not)."""
        with contextlib.suppress(ValueError):
            self._request_listeners.remove(listener)

    def add_load_listener(self, listener: Callable[[LoadedInstance], None]) -> None:
        """Call *listener* with every instance loaded from now on (started, and listed in :attr:`instances`).

        Instances of other processes (their proxies) included.
        """
        self._load_listeners.append(listener)

    def _loaded(self, instance: LoadedInstance) -> None:
        for listener in list(self._load_listeners):
            listener(instance)
        self.events.publish(InstanceLoaded(instance.instance, instance.genom_name, self.clock.wall()))

    def add_unload_listener(self, listener: Callable[[str], None]) -> None:
        """Call *listener* with the name of every unloaded instance."""
        self._unload_listeners.append(listener)

    def announce_request(self, request: RequestStatus) -> None:
        """Report a request status change to the listeners, and to the subscribers of :attr:`events`."""
        for listener in self._request_listeners:
            listener(request)
        self.events.request_changed(request)

    @property
    def closing(self) -> bool:
        """Whether :meth:`close` has begun (its unloads are the last: the process is ending or the host going)."""
        return self._closing

    async def close(self) -> None:
        """Unload every instance, then close the shared resources (idempotent)."""
        self._closing = True
        for instance in list(self._instances):
            try:
                await self.unload(instance)
            except NoSuchModule:
                pass
        if self._background:
            await asyncio.gather(*self._background, return_exceptions=True)
        await self.clock.aclose()
        shared, self._shared = self._shared, {}
        # Last made, first closed: a resource made from another (a driver on a drive's bus) goes first.
        for key, resource in reversed(shared.items()):
            closer = getattr(resource, "aclose", None)
            if closer is not None:
                try:
                    await closer()
                except Exception:
                    log.exception("closing shared resource %s failed", key)

    async def __aenter__(self) -> ComponentHost:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()


def _check_options(cls: type[Component], args: list[str]) -> None:
    """Refuse load arguments that the component's ``usage_options`` do not list.

    An option listed as ``"-x VALUE"`` takes the next argument as its value; one
    listed as ``"-x"`` stands alone.

    Raises:
        LoadError: naming the first argument that fits no listed option.
    """
    takes_value = {}
    for option, _ in cls.usage_options:
        flag, *value = option.split()
        takes_value[flag] = bool(value)
    listed = ", ".join(option for option, _ in cls.usage_options)
    at = 0
    while at < len(args):
        arg = args[at]
        if arg == "-i":  # the host took the first one
            raise LoadError("-i is given twice")
        if arg not in takes_value:
            shown = repr(arg) if len(arg) <= 60 else repr(arg[:57]) + "..."
            raise LoadError(f"{cls.genom_name} has no load option {shown} (options: {listed})")
        if takes_value[arg] and at + 1 >= len(args):
            raise LoadError(f"load option {arg} of {cls.genom_name} needs a value")
        at += 2 if takes_value[arg] else 1


class _LazyFactory:
    """An entry point imported only when its component is first needed."""

    def __init__(self, entry: importlib.metadata.EntryPoint) -> None:
        self.entry = entry
        self._cls: type[Component] | None = None

    def load(self) -> type[Component]:
        if self._cls is None:
            self._cls = self.entry.load()
        return self._cls

    def __call__(self, *args: Any, **kwargs: Any) -> Component:
        return self.load()(*args, **kwargs)
