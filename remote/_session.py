"""Opening a Zenoh session that talks only to whom it is told, and asking a query from asyncio in bounded time.

Zenoh calls back on its own threads; everything here hands results to the event loop with
``call_soon_threadsafe``, so the rest of the process stays single-threaded.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import pathlib
import time
from collections.abc import Callable
from typing import Any, TypeVar

import json5
import orjson
import zenoh

from ..components.core.runtime import RemoteRefusal, RemoteUnreachable
from ._settings import ZenohSettings
from ._shm import SETTINGS as SHARED_MEMORY
from ._shm import remove_orphaned_segments

__all__ = [
    "ZenohSettings", "zenoh_config", "session_summary", "ZenohSessionError", "open_session", "on_zenoh_thread",
    "ask", "ask_all", "alive",
    "listen_endpoints", "connect_endpoints", "GONE", "Answer", "Unanswered",
]

T = TypeVar("T")


class ZenohSessionError(Exception):
    """The Zenoh session cannot be opened: a malformed endpoint or configuration file, an address in use..."""


#: The keys whose value we choose when neither the command line nor the configuration file sets them.
_ISOLATION = ("mode", "scouting/multicast/enabled", "scouting/gossip/enabled", "listen/endpoints")


def zenoh_config(settings: ZenohSettings) -> zenoh.Config:
    """The Zenoh configuration of a session with *settings*' settings (:meth:`ZenohSettings.config`).

    Raises:
        ZenohSessionError: for a configuration file that cannot be read, or settings whose
            session would talk to nobody.
    """
    _check_endpoints([*settings.connect, *settings.listen])
    if settings.config_file is not None:
        try:
            config = zenoh.Config.from_file(settings.config_file)
        except (zenoh.ZError, OSError, ValueError) as exc:
            raise ZenohSessionError(f"cannot read the Zenoh configuration {settings.config_file}: "
                                    f"{_reason(exc)}") from None
    else:
        config = zenoh.Config()
    default = zenoh.Config()
    path = settings.config_file
    written = _written(path, (*_ISOLATION, *SHARED_MEMORY)) if path is not None else set()
    unset = {key for key in _ISOLATION if key not in written and config.get_json(key) == default.get_json(key)}
    for key, value in SHARED_MEMORY.items():
        # For large messages only, from a smaller pool than Zenoh's (see _shm).
        if key not in written and config.get_json(key) == default.get_json(key):
            config.insert_json5(key, value)
    if "mode" in unset:
        config.insert_json5("mode", '"peer"')
    for key in ("scouting/multicast/enabled", "scouting/gossip/enabled"):
        if settings.scout:
            config.insert_json5(key, "true")
        elif key in unset:
            config.insert_json5(key, "false")
    if settings.listen:
        config.insert_json5("listen/endpoints", json.dumps(settings.listen))
    elif "listen/endpoints" in unset and not settings.scout:
        config.insert_json5("listen/endpoints", "[]")
    if settings.connect:
        config.insert_json5("connect/endpoints", json.dumps(settings.connect))
    if config.get_json("connect/endpoints") not in ("[]", "null"):
        # Start without waiting for a peer that is not up yet (the gateway may start before the robot),
        # and keep trying it in the background.
        if config.get_json("connect/timeout_ms") == default.get_json("connect/timeout_ms"):
            config.insert_json5("connect/timeout_ms", "1000")
        if config.get_json("connect/exit_on_failure") == default.get_json("connect/exit_on_failure"):
            config.insert_json5("connect/exit_on_failure", "false")
    elif not (settings.scout or listen_endpoints(config)):
        raise ZenohSessionError("this Zenoh session would talk to nobody: give --zenoh-connect ENDPOINT, "
                                "--zenoh-listen ENDPOINT, a --zenoh-config file with endpoints, or "
                                "--zenoh-scout to find peers on the local network")
    return config

def session_summary(settings: ZenohSettings, config: zenoh.Config) -> str:
    """What a session of *config* does, in one line for its start-up message (:meth:`ZenohSettings.summary`)."""
    listen = listen_endpoints(config)
    connect = connect_endpoints(config)
    scouting = [what for what, key in (("multicast", "scouting/multicast/enabled"),
                                       ("gossip", "scouting/gossip/enabled"))
                if config.get_json(key) != "false"]
    return (f"listening on {', '.join(listen) or 'nothing'}; connecting to {', '.join(connect) or 'nobody'}; "
            f"scouting {'by ' + ' and '.join(scouting) if scouting else 'off'}"
            + (f"; configuration {settings.config_file}" if settings.config_file else ""))


def _written(path: str, keys: tuple[str, ...]) -> set[str]:
    """The *keys* the configuration file *path* writes, whatever their value.

    Zenoh's configuration cannot tell a value the file wrote from its default; the file itself can.
    A file this cannot read (Zenoh read it) writes nothing as far as it knows: its values that
    differ from Zenoh's defaults are still kept.
    """
    try:
        tree = json5.loads(pathlib.Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return set()
    written = set()
    for key in keys:
        node = tree
        for part in key.split("/"):
            if not isinstance(node, dict) or part not in node:
                break
            node = node[part]
        else:
            written.add(key)
    return written


def listen_endpoints(config: zenoh.Config) -> list[str]:
    """The endpoints a session of *config* listens on."""
    return _endpoints(config.get_json("listen/endpoints"), json.loads(config.get_json("mode")) or "peer")


def connect_endpoints(config: zenoh.Config) -> list[str]:
    """The endpoints a session of *config* connects to."""
    return _endpoints(config.get_json("connect/endpoints"), json.loads(config.get_json("mode")) or "peer")


def _endpoints(raw: str, mode: str = "peer") -> list[str]:
    value = json.loads(raw)
    if isinstance(value, dict):  # per mode, as in Zenoh's defaults
        value = value.get(mode, [])
    return [str(endpoint) for endpoint in value or []]


def _check_endpoints(endpoints: list[str]) -> None:
    for endpoint in endpoints:
        # Zenoh would retry a connect endpoint it cannot parse forever, silently.
        address = endpoint.split("?", 1)[0].split("#", 1)[0]
        protocol, _, place = address.partition("/")
        port = place.rpartition(":")[2]
        if not (protocol.isalnum() and place and port.isdigit() and 0 < int(port) < 65536):
            raise ZenohSessionError(f"{endpoint!r} is not a Zenoh endpoint: write PROTOCOL/ADDRESS:PORT, "
                                    f"e.g. tcp/192.168.1.10:7447")


def _reason(exc: BaseException) -> str:
    # Zenoh's message ends with the place in its Rust sources: not for the user.
    return str(exc).split(" at /", 1)[0].rstrip(".")


def open_session(settings: ZenohSettings) -> tuple[zenoh.Session, zenoh.Config]:
    """Open a Zenoh session (blocking: call it in a thread); return it with its configuration.

    Raises:
        ZenohSessionError: for a malformed endpoint or configuration, or an endpoint that cannot be
            listened on.
    """
    config = settings.config()
    remove_orphaned_segments()  # what killed processes left in /dev/shm, before this one adds its own
    try:
        return zenoh.open(config), config
    except zenoh.ZError as exc:
        reason = _reason(exc)
        if reason.startswith("Unable to connect"):  # a client reaches its router, or fails: say why it failed
            from ._links import why_unlinked

            reason = "; ".join(f"no link to {endpoint}: {why_unlinked(endpoint)}"
                               for endpoint in connect_endpoints(config)) or reason
        raise ZenohSessionError(f"cannot open the Zenoh session ({settings.summary(config)}): {reason}; "
                                f"check --zenoh-connect, --zenoh-listen (e.g. tcp/192.168.1.10:7447) and "
                                f"--zenoh-config") from None


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


class Gone:
    """What a pending query's future is given when its host is known to be gone (it is no reply body)."""


#: The one :class:`Gone`.
GONE = Gone()


class _Ended:
    """What a query's future is given when Zenoh ended the query with no reply before its timeout."""


_ENDED = _Ended()

#: A pending query's result: a reply's body, None (no reply within the timeout), GONE, or _ENDED.
Answer = bytes | None | Gone | _Ended


class Unanswered(RemoteUnreachable):
    """Zenoh ended a query, before its timeout, with no reply: nothing answers its key any more.

    Zenoh ends a query early when no queryable matches its key (the host withdrew the instance,
    or its process is gone and the network knows it) or when the queryables it reached went away
    without replying (the host's process died, its link closed).  Either way no answer is coming:
    it is not a timeout, and is not reported as one.
    """


async def ask(session: zenoh.Session, key: str, payload: Any, timeout: float, *, what: str,
              pending: set[asyncio.Future[Answer]] | None = None) -> Any:
    """Ask the query *key* with the JSON *payload*; return the ``ok`` result of the first reply.

    Args:
        session: The Zenoh session.
        key: The query's key.
        payload: Its JSON payload.
        timeout: Seconds Zenoh waits for a reply.
        what: What is asked, for the messages (``send of demo on robot1``).
        pending: Where the query's future is kept while it waits: whoever learns that the host is
            gone sets each to :data:`GONE`, which ends the wait at once rather than at the timeout.

    Raises:
        RemoteRefusal: when the component refused (its genomix error, to be answered as such).
        Unanswered: when Zenoh ended the query before *timeout* with no reply (nothing answers
            *key* now: withdrawn, or its host went away), or its host was found gone meanwhile.
        RemoteUnreachable: when no reply came within *timeout* seconds.
    """
    loop = asyncio.get_running_loop()
    answer: asyncio.Future[Answer] = loop.create_future()

    def settle(value: Answer) -> None:
        if not answer.done():
            answer.set_result(value)

    replied = False  # set on Zenoh's thread, which calls on_reply and on_end one after the other

    def on_reply(reply: zenoh.Reply) -> None:
        nonlocal replied
        body = reply.ok.payload.to_bytes() if reply.ok is not None else None
        if body is not None and not replied:
            replied = True
            loop.call_soon_threadsafe(settle, body)

    def on_end() -> None:
        if replied:
            return  # the reply settled it: the end need not wake the event loop a second time per call
        # Timed here, on Zenoh's thread: a late event loop must not turn an early end into a timeout.
        # Zenoh's own timer starts after *sent* and never fires early, so an end before *timeout* is
        # never Zenoh giving up.
        early = time.monotonic() - sent < timeout
        loop.call_soon_threadsafe(settle, _ENDED if early else None)

    if pending is not None:
        pending.add(answer)
    # With a callback, get() returns at once: the replies come on Zenoh's threads.  Express: sent at once,
    # not held to be batched with other messages (a request waits on it).
    # One queryable answers each key: no consolidation to wait for.
    try:
        sent = time.monotonic()
        session.get(key, on_zenoh_thread(on_reply, on_end), payload=orjson.dumps(payload), timeout=timeout,
                    express=True, consolidation=zenoh.ConsolidationMode.NONE)
        # Zenoh ends the query at its timeout (on_end); the margin covers a callback thread that is late.
        handle = loop.call_later(timeout + 1.0, settle, None)
        try:
            body = await answer
        finally:
            handle.cancel()
    finally:
        if pending is not None:
            pending.discard(answer)
    if body is None:
        raise RemoteUnreachable(f"{what}: no answer within {timeout:g} s (its host is frozen, or the network "
                                f"between is cut)")
    if isinstance(body, _Ended):
        raise Unanswered(f"{what}: nothing answers it any more (its host withdrew it, or went away, before "
                         f"answering)")
    if isinstance(body, Gone):
        raise Unanswered(f"{what}: its host went away, or withdrew it, before answering")
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
