"""The synchronous client: the async core run on a private loop thread, for scripts, the REPL and Jupyter."""

from __future__ import annotations

import concurrent.futures
import dataclasses
from collections.abc import Callable, Coroutine
from typing import Any, Self, TypeVar

from ._async_client import AsyncClient, AsyncModule
from ._ctrl_c import wait_until
from ._errors import RequestTimeout
from ._loop_thread import LoopThread
from ._module import ModuleProxy, build_members, dress
from ._request import AsyncRequest
from ._service import USE_CLIENT_DEFAULT, PortSpec, ServiceSpec
from ._types import Record
from ._wire import GatewayClock, Status

__all__ = ["Client", "Module", "Request", "connect"]

_T = TypeVar("_T")


class Request:
    """A request sent with ``ack=True`` (the blocking call's handle): python-genomix's request object.

    Attributes:
        id: The request id, ``"<instance>::<n>"``.
        module: The module instance.
        service: The service name.
    """

    def __init__(self, handle: AsyncRequest, client: Client) -> None:
        self._handle = handle
        self._client = client
        self.id = handle.id
        self.module = handle.module
        self.service = handle.service

    def __repr__(self) -> str:
        return f"<request {self.id} {self.service} {self.status.value}>"

    @property
    def status(self) -> Status:
        """``Status.sent`` while running, then ``Status.done`` or ``Status.error`` (equal to the strings)."""
        return self._handle.status

    @property
    def done(self) -> bool:
        """Whether the request has ended."""
        return self._handle.done

    @property
    def output(self) -> Record | None:
        """All outputs by name once done."""
        return self._handle.output

    @property
    def exception(self) -> Exception | None:
        """The error it ended with, if any."""
        return self._handle.exception

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the request ends or *timeout* seconds pass; return whether it ended."""
        return wait_until(self._handle.ended_event.wait, timeout)

    def result(self, timeout: Any = USE_CLIENT_DEFAULT) -> Any:
        """Block until the end; return the outputs as the blocking call does.

        Raises:
            RemoteError: the exception it ended with (a generated class, or Interrupted).
            RequestTimeout: when *timeout* expires first; the request keeps running.
        """
        limit = self._client._core._timeout(timeout)
        if not self.wait(limit):
            raise RequestTimeout(f"{self.service} ({self.id}) did not end within {limit} s; it still runs: "
                                 "wait for it again or abort() it", request=self)
        if self._handle.exception is not None:
            raise self._handle.exception
        return self._handle._spec.result(self._handle.output or Record())

    def abort(self, timeout: Any = USE_CLIENT_DEFAULT) -> None:
        """Interrupt the request (it ends with Interrupted, ``by="abort"``); no-op once ended."""
        if not self.done:
            self._client._run(self._handle.abort(self._client._core._timeout(timeout)))


class Module(ModuleProxy):
    """A module instance seen through a :class:`Client`; its service and port functions block."""


class Client:
    """A genomix session on a gateway, with blocking calls.

    Prefer :func:`connect`. Every argument is the same as :class:`AsyncClient`'s.
    """

    def __init__(self, address: str | None = None, **options: Any) -> None:
        self._thread = LoopThread()
        self._core = AsyncClient(address, **options)
        self._modules: dict[str, Module] = {}
        self._callbacks: concurrent.futures.ThreadPoolExecutor | None = None
        self._closed = False

    def __repr__(self) -> str:
        return repr(self._core).replace("AsyncClient", "Client")

    @property
    def url(self) -> str:
        """The gateway's base URL."""
        return self._core.url

    @property
    def session(self) -> str:
        """The genomix session name."""
        return self._core.session

    @property
    def genomix_version(self) -> str:
        """The genomix protocol version the gateway speaks."""
        return self._core.genomix_version

    @property
    def modules(self) -> dict[str, Module]:
        """The modules this client has loaded or looked up, by instance name."""
        current = self._core.modules
        return {name: m for name, m in self._modules.items() if name in current}

    def pending(self) -> list[Request]:
        """The requests of this client that have not ended (e.g. after a Ctrl-C in a blocking call)."""
        return [self._wrap(h) for h in self._core.pending()]

    def _run(self, coro: Coroutine[Any, Any, _T]) -> _T:
        return self._thread.run(coro)

    # -- lifetime ------------------------------------------------------------------------------------

    def open(self) -> Self:
        """Start the session and its event stream (:func:`connect` does it)."""
        try:
            self._run(self._core.open())
        except BaseException:
            self.close()
            raise
        return self

    def close(self) -> None:
        """Stop the session and the client's thread; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        try:
            self._run(self._core.aclose())
        finally:
            self._thread.close()
            if self._callbacks is not None:
                # Callbacks already running finish on their thread; none are waited for here,
                # so a callback may itself close the client.
                self._callbacks.shutdown(wait=False)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- modules ---------------------------------------------------------------------------------------

    def load(self, name: str, *argv: str, timeout: Any = USE_CLIENT_DEFAULT) -> Module:
        """Load a component (or find it loaded); see :meth:`AsyncClient.load` (plugin paths map to names)."""
        return self._module(self._run(self._core.load(name, *argv, timeout=timeout)))

    def module(self, instance: str, *, timeout: Any = USE_CLIENT_DEFAULT) -> Module:
        """The module object of an instance already loaded (by anyone)."""
        return self._module(self._run(self._core.module(instance, timeout=timeout)))

    def __getitem__(self, instance: str) -> Module:
        return self.module(instance)

    def unload(self, instance: str, *, timeout: Any = USE_CLIENT_DEFAULT) -> None:
        """Unload an instance."""
        self._run(self._core.unload(instance, timeout=timeout))
        self._modules.pop(instance, None)

    def loaded(self, *, timeout: Any = USE_CLIENT_DEFAULT) -> dict[str, str]:
        """The instances loaded on the gateway, ``{instance: component}``."""
        return self._run(self._core.loaded(timeout=timeout))

    def clock(self, *, timeout: Any = USE_CLIENT_DEFAULT) -> GatewayClock | None:
        """The gateway's clock now: the time its rig stamps the ports' data with (None from a genomixd)."""
        return self._run(self._core.clock(timeout=timeout))

    def _module(self, core: AsyncModule) -> Module:
        description = core._description
        instance = description.instance
        members = build_members(description, lambda s: self._service_function(instance, s),
                                lambda p: self._port_function(instance, p))
        module: Module = Module.create(description, members)
        self._modules[instance] = module
        return module

    # -- calls -------------------------------------------------------------------------------------------

    def _service_function(self, instance: str, spec: ServiceSpec) -> Callable[..., Any]:
        def service(*args: Any, **kwargs: Any) -> Any:
            inputs, options = spec.bind(args, kwargs)
            if options.callback is not None:
                options = dataclasses.replace(options, callback=self._callback(options.callback))
            try:
                outcome = self._run(self._core.send(instance, spec, inputs, options))
            except RequestTimeout as exc:
                if isinstance(exc.request, AsyncRequest):
                    exc.request = self._wrap(exc.request)
                raise
            return self._wrap(outcome) if isinstance(outcome, AsyncRequest) else outcome

        return dress(service, name=spec.pyname, qualname=f"{instance}.{spec.pyname}", signature=spec.signature,
                     doc=spec.doc)

    def _port_function(self, instance: str, port: PortSpec) -> Callable[..., Any]:
        def read(name: str | None = None, *, since: int | None = None, raw: bool = False,
                 timeout: Any = USE_CLIENT_DEFAULT) -> Any:
            return self._run(self._core.read(instance, port, name, since=since, raw=raw, timeout=timeout))

        return dress(read, name=port.pyname, qualname=f"{instance}.{port.pyname}", signature=port.signature,
                     doc=port.doc)

    def _wrap(self, handle: AsyncRequest) -> Request:
        facade = handle.facade
        if not isinstance(facade, Request):
            facade = handle.facade = Request(handle, self)
        return facade

    def _callback(self, callback: Callable[[Request], Any]) -> Callable[[AsyncRequest], None]:
        # User callbacks run on their own thread: there they may call the client, which the
        # loop thread could not do without waiting for itself.
        if self._callbacks is None:
            self._callbacks = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="aiogenomix-callback")
        executor = self._callbacks
        loop = self._thread.loop

        def run(request: Request) -> None:
            try:
                callback(request)
            except Exception as exc:  # reported, not swallowed: nobody awaits a callback
                self._thread.call_soon(loop.call_exception_handler,
                                       {"message": f"callback of {request.id} failed", "exception": exc})

        def on_end(handle: AsyncRequest) -> None:
            request = self._wrap(handle)
            if not self._closed:
                executor.submit(run, request)

        return on_end


def connect(address: str | None = None, **options: Any) -> Client:
    """Open a blocking :class:`Client` on a gateway.

    Use ``client = connect("host:port")``, or ``with connect() as client``.

    Args:
        address: ``host:port`` (default ``localhost:8080``), or a URL.
        **options: ``session``, ``timeout`` (default of blocking calls), ``token``,
            ``reconnect_timeout``; see :class:`AsyncClient`.

    Returns:
        An open :class:`Client`. Close it (or leave the ``with`` block) to stop the session.

    Raises:
        TransportError: when the gateway cannot be reached.
    """
    return Client(address, **options).open()
