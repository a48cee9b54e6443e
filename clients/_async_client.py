"""The asynchronous client: one genomix session, its event stream, loaded modules and their requests."""

from __future__ import annotations

import asyncio
import inspect
import json
import posixpath
from collections.abc import AsyncIterator, Callable, Generator
from typing import Any, Self

import aiohttp
import orjson

from ._binary import BINARY_TYPE, decode_binary
from ._fastjson import loads_with_arrays
from ._errors import ClientClosed, GenomixError, ProtocolError, RemoteError, RequestTimeout
from ._http import HttpGateway
from ._listen import ListenStream
from ._module import ModuleDescription, ModuleProxy, build_members, dress
from ._request import AsyncRequest
from ._service import USE_CLIENT_DEFAULT, CallOptions, PortSpec, ServiceSpec
from ._streams import PortEvent, SessionEvent, session_events, watch_port
from ._tracker import RequestTracker
from ._wire import GatewayClock, base_url, check_info, clock_of, parse_status

__all__ = ["AsyncClient", "AsyncModule", "aconnect", "component_name"]


#: Seconds allowed to start the session and attach its stream (calls have their own timeout).
_OPEN_TIMEOUT = 30.0

#: Seconds at least allowed for the reply to a send, which names the request: cut short by a call's
#: own (possibly tiny) timeout, it would leave a request running on the robot that no one can abort.
_SEND_REPLY_TIMEOUT = 10.0


def component_name(name: str) -> str:
    """The component to load for *name*: a plugin path ``/x/y/demo.so`` becomes ``demo``.

    python-genomix scripts load plugin files by path; the gateway only loads
    registered components by name (a path is refused), so the client keeps the basename.
    """
    if "/" in name or name.endswith(".so"):
        base = posixpath.basename(name.rstrip("/"))
        return base.removesuffix(".so")
    return name


class AsyncModule(ModuleProxy):
    """A module instance seen through an :class:`AsyncClient`; its service and port functions are coroutines.

    ``await demo.GotoPosition(0.5)`` blocks until the end; ``await demo.GotoPosition(1, ack=True)``
    returns an :class:`AsyncRequest` as soon as the gateway has it.
    """


class AsyncClient:
    """A genomix session on a gateway, for asyncio code.

    Use ``async with AsyncClient("host:port") as client`` or ``client = await aconnect(...)``.

    Args:
        address: ``host:port`` (default ``localhost:8080``), or a URL.
        session: The session name (default: a unique one chosen by the gateway).
        timeout: Default timeout in seconds of blocking calls and replies (None: no limit).
        token: Bearer token, for a gateway started with ``--token``.
        reconnect_timeout: Seconds without an event stream after which pending requests
            fail with TransportError (reconnection continues).
        fast_paths: Use the gateway's binary port reads when it offers them (False: plain
            genomix JSON, as with any genomixd).
    """

    def __init__(self, address: str | None = None, *, session: str | None = None, timeout: float | None = None,
                 token: str | None = None, reconnect_timeout: float = 30.0, fast_paths: bool = True) -> None:
        self.url = base_url(address)
        self._fast_paths = fast_paths
        self.timeout = timeout
        self._session_wanted = session or ""
        self._token = token
        self._reconnect_timeout = reconnect_timeout
        self._http: aiohttp.ClientSession | None = None
        self._gateway: HttpGateway | None = None
        self._tracker: RequestTracker | None = None
        self._listen: ListenStream | None = None
        self._modules: dict[str, AsyncModule] = {}
        self._tasks: set[asyncio.Task[Any]] = set()
        self._opened = False
        self._closed: ClientClosed | None = None
        #: The genomix protocol version the gateway speaks (``/version``).
        self.genomix_version = ""
        #: What the gateway offers beyond genomix (``binary``, ``since``, ``watch``, ``wait``).
        self.features: frozenset[str] = frozenset()
        #: Called with each AsyncModule built (the sync client wraps them).
        self.on_module: Callable[[AsyncModule], None] | None = None

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open" if self._opened else "not connected"
        return f"<aiogenomix AsyncClient {self.url} session {self.session or '-'} {state}>"

    @property
    def session(self) -> str:
        """The genomix session name."""
        return self._gateway.session_name if self._gateway else ""

    @property
    def modules(self) -> dict[str, AsyncModule]:
        """The modules this client has loaded or looked up, by instance name."""
        return dict(self._modules)

    def pending(self) -> list[AsyncRequest]:
        """The requests of this client that have not ended."""
        return self._tracker.pending() if self._tracker else []

    # -- lifetime --------------------------------------------------------------------------------

    async def open(self) -> Self:
        """Start the session and its event stream (done by ``async with`` and :func:`aconnect`).

        Raises:
            TransportError: when the gateway cannot be reached.
        """
        if self._closed:
            raise ClientClosed("this client was closed; create a new one")
        if self._opened:
            return self
        headers = {"Authorization": f"Bearer {self._token}"} if self._token else None
        # No pooled-connection limit: the listen stream holds one connection for ever.
        # A large read buffer: port replies of megabytes arrive without pausing the socket every 64 kB.
        self._http = aiohttp.ClientSession(headers=headers, connector=aiohttp.TCPConnector(limit=0),
                                           read_bufsize=1 << 22)
        try:
            self._gateway = HttpGateway(self.url, self._http)
            timeout = _OPEN_TIMEOUT
            self.genomix_version = (await self._gateway.get_text("/version", timeout=timeout)).strip()
            self.features = await self._read_features(timeout) if self._fast_paths else frozenset()
            name = await self._gateway.get_text("/session/start", {"s": self._session_wanted}, timeout=timeout)
            self._gateway.session_name = name.strip()
            self._tracker = RequestTracker(self._gateway, self._report)
            self._listen = ListenStream(self._gateway, self._tracker, on_unload=self._on_unload,
                                        on_quit=self._on_quit, report=self._report,
                                        reconnect_timeout=self._reconnect_timeout)
            await self._listen.start(timeout)
        except BaseException:
            await self._http.close()
            raise
        self._opened = True
        return self

    async def _read_features(self, timeout: float) -> frozenset[str]:
        """The extensions listed by an aiogenomix gateway at ``/`` (none from a plain genomixd)."""
        assert self._gateway is not None
        try:
            index = await self._gateway.get_json("/", timeout=timeout)
        except (RemoteError, ProtocolError):
            return frozenset()
        features = index.get("features", []) if isinstance(index, dict) else []
        return frozenset(f for f in features if isinstance(f, str))

    async def aclose(self) -> None:
        """Stop the session (``/session/stop``) and release everything; safe to call twice.

        Pending requests keep running on their components; their handles fail with ClientClosed.
        """
        if self._closed is not None and self._http is None:
            return
        self._closed = self._closed or ClientClosed("the client was closed")
        try:
            if self._tracker is not None and self._gateway is not None:
                try:
                    async with asyncio.timeout(5.0):
                        await self._tracker.close(self._closed)
                        await self._gateway.get_text("/session/stop")
                except (GenomixError, TimeoutError):
                    pass  # the gateway is gone or already stopped the session: nothing left to stop
            if self._listen is not None:
                await self._listen.stop()
            for task in list(self._tasks):
                task.cancel()
            if self._tasks:
                await asyncio.gather(*self._tasks, return_exceptions=True)
        finally:
            if self._http is not None:
                await self._http.close()
                self._http = None

    async def __aenter__(self) -> Self:
        return await self.open()

    async def __aexit__(self, *exc: object) -> None:
        await self.aclose()

    def _check_open(self) -> HttpGateway:
        if self._closed is not None:
            raise self._closed
        if not self._opened or self._gateway is None:
            raise ClientClosed("the client is not connected: use `async with` or `await aconnect(...)`")
        return self._gateway

    def _timeout(self, given: Any) -> float | None:
        return self.timeout if given is USE_CLIENT_DEFAULT else given

    # -- modules -----------------------------------------------------------------------------------

    async def load(self, name: str, *argv: str, timeout: Any = USE_CLIENT_DEFAULT) -> AsyncModule:
        """Load a component (or find it already loaded) and return its module object.

        Args:
            name: The component name. A plugin path such as ``/opt/lib/genom/demo.so``
                (python-genomix style) loads the component ``demo``.
            *argv: Load options, e.g. ``"-i", "demo2"`` for a second instance.
            timeout: Seconds to wait (default: the client's).

        Raises:
            NotFound: for a component the gateway does not have.
            InvalidInput: for bad options.
        """
        gateway = self._check_open()
        params = {"argv": json.dumps(list(argv))} if argv else {}
        instance = await gateway.get_text(f"/load/{component_name(name)}", params, timeout=self._timeout(timeout))
        return await self.module(instance.strip(), timeout=timeout)

    async def module(self, instance: str, *, timeout: Any = USE_CLIENT_DEFAULT) -> AsyncModule:
        """The module object of an instance already loaded (by anyone), built from a fresh ``/info``.

        Raises:
            NotFound: when no such instance is loaded.
            HostUnreachable: when it ran on a component host that is gone (or does not answer).
        """
        gateway = self._check_open()
        info = check_info(await gateway.get_json(f"/module/{instance}/info", timeout=self._timeout(timeout),
                                                 module=instance))
        description = ModuleDescription(info)
        module: AsyncModule = AsyncModule.create(description, build_members(
            description, lambda spec: self._service_function(description.instance, spec),
            lambda port: self._port_function(description.instance, port)))
        self._modules[description.instance] = module
        if self.on_module is not None:
            self.on_module(module)
        return module

    async def unload(self, instance: str, *, timeout: Any = USE_CLIENT_DEFAULT) -> None:
        """Unload an instance (every session gets an ``unload`` event)."""
        gateway = self._check_open()
        await gateway.get_text(f"/unload/{instance}", timeout=self._timeout(timeout), module=instance)
        self._modules.pop(instance, None)

    async def clock(self, *, timeout: Any = USE_CLIENT_DEFAULT) -> GatewayClock | None:
        """The gateway's clock now: the time its rig stamps the ports' data with (None from a genomixd)."""
        return clock_of(await self._check_open().get_json("/", timeout=self._timeout(timeout)))

    async def loaded(self, *, timeout: Any = USE_CLIENT_DEFAULT) -> dict[str, str]:
        """The instances loaded on the gateway, ``{instance: component}``."""
        index = await self._check_open().get_json("/", timeout=self._timeout(timeout))
        if not isinstance(index, dict) or not isinstance(index.get("loaded", {}), dict):
            raise ProtocolError(f"/ did not describe the gateway: {index!r:.200}")
        return dict(index.get("loaded", {}))

    # -- event streams ---------------------------------------------------------------------------

    def watch(self, instance: str, port: str, *, since: int | None = None, name: str | None = None
              ) -> AsyncIterator[PortEvent]:
        """The publications of a port as they come: ``async for event in client.watch("kemar", "currentState")``.

        Each :class:`PortEvent` holds the port's data as genomix JSON and what was lost.  For
        numbered data (the audio window) each event holds only the items not had yet, ``since``
        an item index at first (default: with the newest publication's); a stream that drops is
        opened again where it was.  Other data comes as its latest value, ``lost`` counting the
        publications skipped while the reader was busy.

        Args:
            instance: The module instance.
            port: The out port.
            since: Numbered data only: start after this item.
            name: The element of a multiple port.

        Raises:
            ModuleUnloaded: when the instance is unloaded (the stream ends).
            NotFound, InvalidInput: for an unknown instance or port, or a ``since`` that does not apply.
            TransportError: when the stream drops and cannot be opened again.
        """
        return watch_port(self._check_open(), instance, port, since=since, element=name)

    def session_events(self, session: str) -> AsyncIterator[SessionEvent]:
        """The events of any session (``request``, ``unload``, ``quit``) until it stops, for a logger or a recorder.

        This is one more listener of the session.  A session not started yet is started by it
        (genomix clients may listen before they start), and the events a session kept while
        nobody listened go to the first listener that comes: listen after the session's own
        client does, or those events come here instead of there.  A stream that drops is opened
        again; the events of the time in between come only if nobody else listened meanwhile.

        Raises:
            InvalidInput: for a name that cannot name a session.
            TransportError: when the stream drops and cannot be opened again.
        """
        return session_events(self._check_open(), session)

    # -- calls -------------------------------------------------------------------------------------

    def _service_function(self, instance: str, spec: ServiceSpec) -> Callable[..., Any]:
        async def service(*args: Any, **kwargs: Any) -> Any:
            inputs, options = spec.bind(args, kwargs)
            if options.callback is not None:
                options = CallOptions(options.ack, self._user_callback(options.callback), options.oneway,
                                      options.timeout)
            return await self.send(instance, spec, inputs, options)

        return dress(service, name=spec.pyname, qualname=f"{instance}.{spec.pyname}", signature=spec.signature,
                     doc=spec.doc)

    def _port_function(self, instance: str, port: PortSpec) -> Callable[..., Any]:
        async def read(name: str | None = None, *, since: int | None = None, raw: bool = False,
                       timeout: Any = USE_CLIENT_DEFAULT) -> Any:
            return await self.read(instance, port, name, since=since, raw=raw, timeout=timeout)

        return dress(read, name=port.pyname, qualname=f"{instance}.{port.pyname}", signature=port.signature,
                     doc=port.doc)

    async def send(self, instance: str, spec: ServiceSpec, inputs: dict[str, Any], options: CallOptions) -> Any:
        """Send a request with already encoded *inputs*; what the generated functions call.

        Returns:
            None with ``oneway``; the :class:`AsyncRequest` with ``ack``; otherwise the outputs.
        """
        gateway = self._check_open()
        assert self._tracker is not None
        timeout = self._timeout(options.timeout)
        loop = asyncio.get_running_loop()
        deadline = None if timeout is None else loop.time() + timeout
        # Raw UTF-8, as genom3 expects: it does not decode \uXXXX escapes (see docs/protocol.md).
        params = {"input": json.dumps(inputs, separators=(",", ":"), ensure_ascii=False)}
        if options.oneway:
            params["oneway"] = "1"
        epoch = self._tracker.epoch
        # The call's timeout bounds the wait for the end; the send's reply gets at least
        # _SEND_REPLY_TIMEOUT, so that a RequestTimeout always carries a request that can be aborted.
        send_timeout = None if timeout is None else max(timeout, _SEND_REPLY_TIMEOUT)
        reply = parse_status(await gateway.get_json(f"/module/{instance}/send/{spec.name}", params,
                                                    timeout=send_timeout, module=instance, service=spec.name))
        if options.oneway:
            return None
        handle = AsyncRequest(reply["id"], instance, spec, abort=self._abort, epoch=epoch)
        if options.callback is not None:
            handle.add_done_callback(options.callback)
        self._tracker.register(handle, reply)
        if options.ack:
            return handle
        if not await handle.wait(None if deadline is None else max(0.0, deadline - loop.time())):
            raise RequestTimeout(f"{spec.name} ({handle.id}) did not end within {timeout} s; it still runs: "
                                 "wait for it or abort() it (the exception's .request)", request=handle)
        return await handle.result()

    async def read(self, instance: str, port: PortSpec, element: str | None = None, *, since: int | None = None,
                   raw: bool = False, timeout: Any = USE_CLIENT_DEFAULT) -> Any:
        """Read a port; what the generated port functions call.

        The binary form is used when the gateway offers it (``/`` lists
        ``binary``), except for ``raw`` reads, which return the genomix JSON.
        """
        gateway = self._check_open()
        params = {"name": element} if element is not None else {}
        if since is not None:
            params["since"] = str(int(since))
        path = f"/module/{instance}/read/{port.name}"
        kwargs: dict[str, Any] = {"timeout": self._timeout(timeout), "module": instance, "service": port.name}
        if "binary" in self.features and not raw:
            ctype, body = await gateway.get(path, params | {"format": "binary"}, **kwargs)
            if ctype == BINARY_TYPE:
                _, data, extra = decode_binary(body)
                decoded = port.decode(data)
                return (decoded, int(extra.get("lost", 0))) if since is not None else decoded
        else:
            _, body = await gateway.get(path, params, **kwargs)
        try:
            wrapped = orjson.loads(body) if raw else loads_with_arrays(body, port.name, port.numeric_members)
        except orjson.JSONDecodeError:
            raise ProtocolError(f"read {instance}/{port.name}: expected JSON, got {body[:200]!r}") from None
        if raw:
            return wrapped
        if not isinstance(wrapped, dict) or port.name not in wrapped:
            raise ProtocolError(
                f"read {instance}/{port.name}: expected {{{port.name!r}: data}}, got {wrapped!r:.200}")
        decoded = port.decode(wrapped[port.name])
        return (decoded, int(wrapped.get("lost", 0))) if since is not None else decoded

    async def _abort(self, handle: AsyncRequest, timeout: float | None) -> None:
        gateway = self._check_open()
        assert self._tracker is not None
        try:
            status = await gateway.abort(handle.module, handle.id, timeout)
        except RequestTimeout as exc:
            exc.request = handle
            raise
        self._tracker.on_reply(handle, status)

    def _user_callback(self, callback: Callable[[Any], Any]) -> Callable[[AsyncRequest], None]:
        def on_end(handle: AsyncRequest) -> None:
            try:
                outcome = callback(handle)
                if inspect.isawaitable(outcome):
                    self._spawn(outcome)
            except Exception as exc:  # reported, not swallowed: nobody awaits a callback
                self._report({"message": f"callback of {handle.id} failed", "exception": exc})

        return on_end

    def _spawn(self, awaitable: Any) -> None:
        task = asyncio.ensure_future(awaitable)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- events --------------------------------------------------------------------------------------

    def _on_unload(self, instance: str) -> None:
        self._modules.pop(instance, None)

    def _on_quit(self) -> None:
        if self._closed is None:
            self._closed = ClientClosed(f"session {self.session} was stopped by someone else")
            if self._tracker is not None:
                self._tracker.fail_pending(self._closed)

    def _report(self, context: dict[str, Any]) -> None:
        asyncio.get_running_loop().call_exception_handler(context)

    def _drop_listen_stream(self) -> None:
        """Cut the event stream's connection as a network failure would (for tests)."""
        if self._listen is not None:
            self._listen._drop()


class _Connecting:
    """What :func:`aconnect` returns: await it, or use it with ``async with``."""

    def __init__(self, client: AsyncClient) -> None:
        self._client = client

    def __await__(self) -> Generator[Any, None, AsyncClient]:
        return self._client.open().__await__()

    async def __aenter__(self) -> AsyncClient:
        return await self._client.open()

    async def __aexit__(self, *exc: object) -> None:
        await self._client.aclose()


def aconnect(address: str | None = None, **options: Any) -> _Connecting:
    """Open an :class:`AsyncClient` on a gateway.

    Use ``client = await aconnect("host:port")`` or ``async with aconnect() as client``.

    Args:
        address: ``host:port`` (default ``localhost:8080``).
        **options: See :class:`AsyncClient`.
    """
    return _Connecting(AsyncClient(address, **options))
