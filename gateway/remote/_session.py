"""Opening a Zenoh session on chosen endpoints, and asking a query from asyncio with a bounded time.

Zenoh calls back on its own threads; everything here hands results to the event loop with
``call_soon_threadsafe``, so the rest of the gateway stays single-threaded.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import json
from collections.abc import Callable
from typing import Any, TypeVar

import orjson
import zenoh

from .._errors import RemoteRefusal, RemoteUnreachable, ZenohSessionError

__all__ = ["ZenohEndpoints", "open_session", "on_zenoh_thread", "ask", "ask_all", "alive"]

T = TypeVar("T")


@dataclasses.dataclass
class ZenohEndpoints:
    """Where a Zenoh session listens and whom it connects to.

    Attributes:
        connect: Endpoints to connect to, such as ``tcp/192.168.1.10:7447``.
        listen: Endpoints to listen on, such as ``tcp/0.0.0.0:7447``.
        scouting: Find peers by multicast scouting.  Off whenever endpoints are given: a session
            told whom to talk to talks to nobody else (no accidental discovery across a lab network).
    """

    connect: list[str] = dataclasses.field(default_factory=list)
    listen: list[str] = dataclasses.field(default_factory=list)
    scouting: bool | None = None

    def config(self) -> zenoh.Config:
        """The Zenoh configuration of a peer with these endpoints."""
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        scouting = self.scouting if self.scouting is not None else not (self.connect or self.listen)
        config.insert_json5("scouting/multicast/enabled", "true" if scouting else "false")
        if self.connect:
            config.insert_json5("connect/endpoints", json.dumps(self.connect))
            # Start without waiting for a peer that is not up yet (the gateway may start before the robot),
            # and keep trying it in the background.
            config.insert_json5("connect/timeout_ms", "1000")
            config.insert_json5("connect/exit_on_failure", "false")
        if self.listen:
            config.insert_json5("listen/endpoints", json.dumps(self.listen))
        return config


def open_session(endpoints: ZenohEndpoints) -> zenoh.Session:
    """Open a Zenoh peer session (blocking: call it in a thread).

    Raises:
        ZenohSessionError: for a malformed endpoint or one that cannot be listened on.
    """
    for endpoint in [*endpoints.connect, *endpoints.listen]:
        # Zenoh would retry a connect endpoint it cannot parse forever, silently.
        address = endpoint.split("?", 1)[0].split("#", 1)[0]
        protocol, _, place = address.partition("/")
        port = place.rpartition(":")[2]
        if not (protocol.isalnum() and place and port.isdigit() and 0 < int(port) < 65536):
            raise ZenohSessionError(f"{endpoint!r} is not a Zenoh endpoint: write PROTOCOL/ADDRESS:PORT, "
                                    f"e.g. tcp/192.168.1.10:7447")
    try:
        return zenoh.open(endpoints.config())
    except zenoh.ZError as exc:
        # Zenoh's message ends with the place in its Rust sources: not for the user.
        reason = str(exc).split(" at /", 1)[0].rstrip(".")
        raise ZenohSessionError(f"cannot open the Zenoh session (connect: {', '.join(endpoints.connect) or 'none'}; "
                                f"listen: {', '.join(endpoints.listen) or 'none'}): {reason}; check "
                                f"--zenoh-connect and --zenoh-listen (e.g. tcp/192.168.1.10:7447)") from None


def on_zenoh_thread(callback: Callable[[Any], None],
                    on_end: Callable[[], None] | None = None) -> zenoh.handlers.Callback[Any]:
    """A Zenoh handler that calls *callback* (and *on_end*) on the Zenoh thread that received the message.

    Zenoh's default handler runs a Python callback on a thread of its own, and a query's handler
    on a thread started for that query (0.5 ms more per round trip).  Every callback here only
    hands the message to the event loop with ``call_soon_threadsafe``: it never holds Zenoh up.
    """
    if on_end is None:
        return zenoh.handlers.Callback(callback, indirect=False)
    return zenoh.handlers.Callback(callback, on_end, indirect=False)


async def ask(session: zenoh.Session, key: str, payload: Any = None, timeout: float = 5.0) -> Any:
    """Ask the query *key* with the JSON *payload*; return the ``ok`` result of the first reply.

    Raises:
        RemoteRefusal: when the component refused (its genomix error, to be answered as such).
        RemoteUnreachable: when no reply came within *timeout* seconds (the process is gone, or
            the network is cut).
    """
    loop = asyncio.get_running_loop()
    answer: asyncio.Future[bytes | None] = loop.create_future()

    def settle(value: bytes | None) -> None:
        if not answer.done():
            answer.set_result(value)

    def on_reply(reply: zenoh.Reply) -> None:
        body = reply.ok.payload.to_bytes() if reply.ok is not None else None
        if body is not None:
            loop.call_soon_threadsafe(settle, body)

    def on_end() -> None:
        loop.call_soon_threadsafe(settle, None)

    # With a callback, get() returns at once: the replies come on Zenoh's threads.  Express: sent at once,
    # not held to be batched with other messages (a request waits on it).
    # One queryable answers each key: no consolidation to wait for.
    session.get(key, on_zenoh_thread(on_reply, on_end), payload=orjson.dumps(payload), timeout=timeout,
                express=True, consolidation=zenoh.ConsolidationMode.NONE)
    try:
        # Zenoh ends the query at its timeout; the margin covers a callback thread that is late.
        async with asyncio.timeout(timeout + 1.0):
            body = await answer
    except TimeoutError:
        body = None
    if body is None:
        raise RemoteUnreachable(f"no answer from {key} within {timeout:g} s: its process is gone or unreachable")
    reply = orjson.loads(body)
    if "error" in reply:
        raise RemoteRefusal(reply["error"]["status"], reply["error"]["body"])
    return reply.get("ok")


async def ask_all(session: zenoh.Session, key: str, timeout: float = 5.0) -> list[bytes]:
    """Every reply to the query *key* (an empty list when nobody answered within *timeout*)."""
    return await _every_reply(lambda handler: session.get(key, handler, timeout=timeout),
                              lambda sample: sample.payload.to_bytes(), timeout)


async def alive(session: zenoh.Session, key: str, timeout: float = 2.0) -> list[str]:
    """The keys of the liveliness tokens matching *key* now."""
    return await _every_reply(lambda handler: session.liveliness().get(key, handler, timeout=timeout),
                              lambda sample: str(sample.key_expr), timeout)


async def _every_reply(get: Callable[[zenoh.handlers.Callback[Any]], Any], take: Callable[[zenoh.Sample], T],
                       timeout: float) -> list[T]:
    """What *take* makes of each good reply to the query that *get* starts with the handler it is given.

    The query ends when every replier answered or at *timeout* (Zenoh's, plus a margin for a late
    end callback): nothing is left pending.
    """
    loop = asyncio.get_running_loop()
    taken: list[T] = []
    finished: asyncio.Future[None] = loop.create_future()

    def on_reply(reply: zenoh.Reply) -> None:
        if reply.ok is not None:
            loop.call_soon_threadsafe(taken.append, take(reply.ok))

    def finish() -> None:
        if not finished.done():
            finished.set_result(None)

    def on_end() -> None:
        loop.call_soon_threadsafe(finish)

    get(on_zenoh_thread(on_reply, on_end))
    with contextlib.suppress(TimeoutError):
        async with asyncio.timeout(timeout + 1.0):
            await finished
    return taken
