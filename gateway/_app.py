"""The application factory: routes, middlewares, and the lifetime of the component host."""

from __future__ import annotations

import asyncio
import sys
from collections.abc import AsyncIterator, Callable

from aiohttp import web

from ..components.core import ComponentHost, ComponentsOffered, ScaledClock
from ..components.core.runtime import keep_heap_settled
from . import _routes_admin, _routes_docs, _routes_modules, _routes_openapi, _routes_ports, _routes_sessions
from ._access import AccessPolicy
from ._auth import TokenCheck
from ._config import GatewayConfig
from ._door import Door
from ._guard import MAX_BODY_BYTES, guard_middleware
from ._foxglove import FoxgloveView
from ._keys import (
    CONFIG, DOOR, FOXGLOVE, HOST, INFO_BODIES, READ_BODIES, SESSIONS, SHUTDOWN, UNLOADS, WATCH_FRAMES, WATCH_WAKES,
    Shutdown, WatchFrames,
)
from ._connection import handler_arguments
from ._info_bodies import InfoBodies
from ._read_bodies import ReadBodies
from ._watch_wakes import WatchWakes
from ._sessions import SessionStore
from ._shutdown import shut_down
from ._unloads import Unloads

__all__ = ["create_app"]


def create_app(config: GatewayConfig | None = None, host: ComponentHost | None = None) -> web.Application:
    """Build the gateway application.

    Args:
        config: The configuration (defaults for everything not given).
        host: A component host to serve (default: one built from *config*, stopped
            when the application shuts down; a host passed in is left open for its owner).

    Returns:
        An aiohttp application; run it with ``web.run_app`` or an ``AppRunner``.
    """
    config = config or GatewayConfig()
    access = config.access
    door = Door(AccessPolicy(list(access.allowed_hosts), list(access.allowed_origins)),
                TokenCheck(access.token) if access.token else None)
    # One middleware: the door, then errors as JSON.  The limits of a connection are aiohttp's
    # handler's, so that whatever runner serves the app applies them (``serve`` adds the
    # refusals in JSON, the head timeout and the plain reads ahead of the routes).
    app = web.Application(middlewares=[guard_middleware(door)], handler_args=handler_arguments(config.connections),
                          client_max_size=MAX_BODY_BYTES)
    app[CONFIG] = config
    app[DOOR] = door
    sessions = config.sessions
    app[SESSIONS] = SessionStore(idle_timeout=sessions.session_idle, max_sessions=sessions.max_sessions)
    app[SHUTDOWN] = Shutdown()
    app[WATCH_FRAMES] = WatchFrames()
    owns_host = host is None
    app[HOST] = host or ComponentHost(clock=ScaledClock(config.clock.time_scale), settings=config.host_settings(),
                                      function_grace=sessions.function_grace, max_instances=sessions.max_instances)
    app[UNLOADS] = Unloads(app[HOST])
    shutdown = app[SHUTDOWN]
    app[READ_BODIES] = ReadBodies(app[UNLOADS], lambda: shutdown.future)
    app[INFO_BODIES] = InfoBodies()
    app[WATCH_WAKES] = WatchWakes(app[UNLOADS], lambda: shutdown.future, sessions.ping_interval)
    app.add_routes(_routes_sessions.routes)
    app.add_routes(_routes_admin.routes)
    app.add_routes(_routes_modules.routes)
    app.add_routes(_routes_ports.routes)
    app.add_routes(_routes_openapi.routes)
    app.add_routes(_routes_docs.routes)
    app.cleanup_ctx.append(_host_lifetime(owns_host))
    app.cleanup_ctx.append(_session_ends)
    view = config.view
    if view.foxglove_port is not None:
        app[FOXGLOVE] = FoxgloveView(view.foxglove_host, view.foxglove_port, door, clock=app[HOST].clock,
                                     max_viewers=view.max_viewers, viewer_bytes=view.viewer_bytes)
        app.cleanup_ctx.append(_foxglove_lifetime)
    app.on_shutdown.append(shut_down(owns_host))
    return app


def _host_lifetime(owns_host: bool) -> Callable[[web.Application], AsyncIterator[None]]:
    async def lifetime(app: web.Application) -> AsyncIterator[None]:
        host, sessions = app[HOST], app[SESSIONS]
        # The host's events reach the sessions as objects, framed by each listen stream in its form.
        subscription = host.events.subscribe(sessions.route, sessions_only=True)
        host.add_unload_listener(app[UNLOADS].notice)
        try:
            if app[CONFIG].uses_zenoh:
                await _find_remote_components(app)
            for item in app[CONFIG].server.preload:
                name, _, args = item.partition(":")
                await host.load(name, args.split())
                # A stop signal while starting is handled between loads, not after the last one.
                await asyncio.sleep(0)
            # What the gateway holds for good, out of the collector's full passes: they stopped the loop for
            # tens of milliseconds.
            keep_heap_settled(host)
        except BaseException:
            # aiohttp cleans up only the contexts that started: close what was loaded.
            if owns_host:
                await host.close()
            raise
        yield  # the shutdown step (_shutdown) stops the components, within a bounded time
        subscription.close()

    return lifetime


async def _session_ends(app: web.Application) -> AsyncIterator[None]:
    """Sessions that end as their idle time passes, and the components told of every end (a recording stops)."""
    sessions, host = app[SESSIONS], app[HOST]
    sessions.add_end_listener(host.end_session)
    expiry = asyncio.create_task(sessions.expire_on_time(), name="session expiry")
    try:
        yield
    finally:
        expiry.cancel()
        await asyncio.gather(expiry, return_exceptions=True)


async def _foxglove_lifetime(app: web.Application) -> AsyncIterator[None]:
    """The live view, from the start (the preloaded instances shown) to the end (after the components stop)."""
    view, host = app[FOXGLOVE], app[HOST]
    await view.start(host.instances)
    hiding: set[asyncio.Task[None]] = set()

    def hide(instance: str) -> None:
        task = asyncio.create_task(view.hide(instance), name=f"foxglove hides {instance}")
        hiding.add(task)
        task.add_done_callback(hiding.discard)

    host.add_load_listener(view.show)
    host.add_unload_listener(hide)
    # (With a view, every request becomes an event object; it is framed only while a viewer subscribes.)
    events = host.events.subscribe(view.show_event)
    try:
        yield
    finally:
        events.close()
        await asyncio.gather(*hiding, return_exceptions=True)
        await view.stop()


async def _find_remote_components(app: web.Application) -> None:
    """Let ``load`` find the components other processes offer on Zenoh (imported only when asked for)."""
    from ..remote import ZenohDirectory

    config, host = app[CONFIG], app[HOST]
    settings = config.zenoh
    directory = await ZenohDirectory.open(
        settings, config.remote_timeouts.with_grace(host.function_grace), local=list(config.remote.local),
        on_offered=lambda offer: host.events.publish(ComponentsOffered(offer, host.clock.wall())))
    print(f"aiogenomix gateway: Zenoh session {directory.zid}: {settings.summary(directory.config)}",
          file=sys.stderr, flush=True)
    host.finder = directory
    # The host closes its shared resources last, after unloading the proxies that use the session.
    host.shared("zenoh", lambda: directory)
