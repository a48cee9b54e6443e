"""Routes of port data: ``read`` (JSON, binary, incremental) and the ``watch`` event stream.

``/module/M/read/PORT`` answers genomix JSON by default.  ``format=binary`` (or
``Accept: application/x-aiogenomix-binary``) answers the binary form, and
``since=K`` on ports whose data is :class:`Incremental` (the audio window)
answers only the chunks after K, with the count of those lost.
``/module/M/watch/PORT`` streams each publication as a server-sent event; a
reader that lags is not queued without bound: it gets what the window still
holds and an explicit ``lost`` count; the stream ends with an ``unload`` event
when the instance is unloaded or killed.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
from typing import Any, cast

import orjson
from aiohttp import web

from ..components.core import Chunked, Incremental, OutPortRuntime, OverBudget
from ..components.core.runtime import BINARY_CONTENT_TYPE, PortUnavailable, RemoteUnreachable, encode_binary
from ._errors import BadQuery
from ._keys import CONFIG, HOST, READ_BODIES, SHUTDOWN, UNLOADS, WATCH_FRAMES, WATCH_WAKES, WatchFrames
from ._gather import Buffer, unlinked
from ._pieces import JOINED_UP_TO, PiecesPayload, body_of, json_pieces
from ._read_bodies import ReadBodies
from ._replies import SERVER_HEADER
from ._sse import FINAL_ID, PING, event_id, event_stream, format_event

__all__ = ["routes", "read_body", "wants_binary", "parse_since", "READ_HEADERS"]

routes = web.RouteTableDef()
#: A ``port`` event of a watch, in pieces to be written in order (one ``bytes`` when small).
Frame = tuple[Buffer, ...]


def wants_binary(fmt: str, accept: str) -> bool:
    """Whether a read gets the binary form, given its ``format`` (checked: empty, json or binary) and ``Accept``."""
    return fmt == "binary" or (not fmt and BINARY_CONTENT_TYPE in accept)


def _wants_binary(request: web.Request) -> bool:
    fmt = request.query.get("format", "")
    if fmt not in ("", "json", "binary"):
        raise BadQuery(f"format must be json or binary, not {fmt!r}")
    return wants_binary(fmt, request.headers.get("Accept", ""))


#: The most digits of a ``since`` (indexes stay below 2**63).
_SINCE_DIGITS = 19


def parse_since(text: str | None) -> int | None:
    """The index a ``since=`` names (None when absent).

    Raises:
        BadQuery: for anything but a number of at most 19 decimal digits.
    """
    if text is None:
        return None
    if not (text.isascii() and text.isdigit() and len(text) <= _SINCE_DIGITS):
        shown = ascii(text if len(text) <= 30 else text[:27] + "...")
        raise BadQuery(f"since must be an item index: a whole number, 0 or more, of at most "
                       f"{_SINCE_DIGITS} digits (not {shown})")
    return int(text)


def _since(request: web.Request) -> int | None:
    return parse_since(request.query.get("since"))


def _port(request: web.Request) -> tuple[str, Any]:
    component = request.app[HOST].get(request.match_info["module"])
    name = request.match_info["port"]
    return name, component.port(name)


def _element(request: web.Request, port: Any) -> str | None:
    """The ``name=`` of a multiple port's element; refused on other ports rather than ignored."""
    element = request.query.get("name")
    if element is not None and not (isinstance(port, OutPortRuntime) and port.spec.multiple):
        raise BadQuery(f"port {port.name} has no elements: name= applies to multiple ports only")
    return element


def _require_incremental(port: Any, value: Any) -> Incremental:
    if not isinstance(value, Incremental):
        raise BadQuery(f"port {port.name} holds no numbered chunks: since= does not apply")
    return value


#: The headers of a read's reply, binary or not.
READ_HEADERS = {binary: {"Content-Type": BINARY_CONTENT_TYPE if binary else "application/json", **SERVER_HEADER}
                for binary in (False, True)}


@functools.lru_cache(maxsize=256)
def _is_chunked(kind: type) -> bool:
    # Once per type: isinstance() with a runtime protocol walks the protocol's members every time.
    return issubclass(kind, Chunked)


def _body(name: str, port: Any, value: Any, binary: bool, extra: dict[str, Any]) -> bytes | PiecesPayload:
    data = None if value is None else port.type.encode(value)
    if binary:
        return body_of(encode_binary(name, data, **extra), BINARY_CONTENT_TYPE)
    return body_of(json_pieces({name: data, **extra}), "application/json")


@routes.get("/module/{module}/read/{port}")
async def read(request: web.Request) -> web.StreamResponse:
    """The latest data of a port: ``{"PORT": data}``, or its binary or incremental forms."""
    name, port = _port(request)
    element = _element(request, port)
    since = _since(request)
    value = port.read(element) if isinstance(port, OutPortRuntime) else port.read()
    binary = _wants_binary(request)
    if since is not None:
        _require_incremental(port, value)
    # An in port answers what it holds: the data of the out port it is connected to (null while it is not).
    bodies = request.app[READ_BODIES] if isinstance(port, OutPortRuntime) else None
    body = read_body(bodies, name, port, value, element, since, binary)
    return web.Response(body=body, headers=READ_HEADERS[binary])


def read_body(bodies: ReadBodies | None, name: str, port: Any, value: Any, element: str | None, since: int | None,
              binary: bool) -> bytes | PiecesPayload:
    """The body of a read of *port*, whose data is *value* (checked: *since* applies to it).

    Also used by the connection's fast path (``_fast_reads``): both answer the same bytes.  Whole
    reads of chunked data are kept per publication in *bodies* (None: made for this read alone, as
    for an in port, whose data is its out port's).
    """
    if _is_chunked(type(value)):  # type: ignore[arg-type]  # a type[Any] is hashable
        # The publication's chunks as they are: no copy of the window, and JSON texts made
        # once per chunk.  The data is immutable, so the reply holds this publication alone
        # however long it takes to write.
        if since is None:
            if bodies is None:
                return _body(name, port, value.chunked(None)[0], binary, {})
            return bodies.body(port, value, (binary, element),
                               lambda of, whole: _body(name, of, whole.chunked(None)[0], binary, {}))
        chunked, lost = value.chunked(since)
        return _body(name, port, chunked, binary, {"lost": lost})
    extra: dict[str, Any] = {}
    if since is not None:
        value, extra["lost"] = value.since(since)
    return _body(name, port, value, binary, extra)


def _watch_frame(frames: WatchFrames, name: str, port: OutPortRuntime[Any], element: str | None, delivered: int,
                 last_index: int | None) -> tuple[Frame, int, int | None]:
    """The next ``port`` event for a reader, shared through *frames*; returns it with the new version and index."""
    newest = port.version
    key = (newest, element, delivered if last_index is None else last_index, last_index is None)
    cached = frames.get(port)
    if cached is not None and cached[0] == key:
        return cached[1], newest, cached[2]
    value = port.read(element)
    if isinstance(value, Incremental):
        # A new watcher starts with the items of the newest publication (a chunk of frames for bass).
        start = value.index - getattr(value, "items_per_publication", 1) if last_index is None else last_index
        # The reader now holds up to the newest item (whatever the struct calls it: index, lastFrameIndex).
        new_index: int | None = value.index
        # Numbered chunks as they are (their JSON texts made once, shared by every watcher and read):
        # a watcher starting at 0 gets the whole window, 150 MB of JSON for the 59 MiB window.
        if _is_chunked(type(value)):
            value, lost = cast(Chunked, value).chunked(max(start, 0))
        else:
            value, lost = value.since(max(start, 0))
    else:
        lost = max(0, newest - delivered - 1) if delivered else 0
        new_index = last_index
    frame = _port_event(json_pieces({name: port.type.encode(value), "lost": lost}))
    frames[port] = (key, frame, new_index)
    return frame, newest, new_index


def _port_event(pieces: list[bytes]) -> Frame:
    """The ``port`` event of the JSON *pieces*: one ``bytes`` when small, else pieces never joined."""
    if len(pieces) == 1 or sum(len(piece) for piece in pieces) <= JOINED_UP_TO:
        return (format_event("port", b"".join(pieces)),)
    return (b"event: port\ndata: " + pieces[0], *pieces[1:-1], pieces[-1] + b"\n\n")


async def _write_event(request: web.Request, stream: web.StreamResponse, frame: Frame, stall: float | None) -> None:
    """Write *frame* to a watcher as it takes it: a large one piece by piece, small pieces joined.

    Each write waits until the connection has taken the one before (aiohttp's flow control): the
    transport never holds a copy of a whole window.  A watcher that takes nothing for *stall*
    seconds (an idle connection's keep-alive time) is disconnected.

    Raises:
        ConnectionResetError: The watcher left, or was disconnected.
    """
    small: list[Buffer] = []
    for piece in (*frame, b""):
        if piece and len(piece) < JOINED_UP_TO:
            small.append(piece)
            continue
        for out in (b"".join(small), piece):
            if not out:
                continue
            try:
                async with asyncio.timeout(stall):
                    await stream.write(out)
            except TimeoutError:
                if request.transport is not None:
                    request.transport.abort()
                raise ConnectionResetError("the watcher took nothing of its event") from None
            except ConnectionError as exc:
                raise unlinked(exc) from None
        small = []


@routes.get("/module/{module}/watch/{port}")
async def watch(request: web.Request) -> web.StreamResponse:
    """Stream the port's publications as ``port`` events until the client leaves.

    Each event is ``{"PORT": data, "lost": n}``.  The current data comes first.
    For incremental data (the audio window) ``data`` holds only the chunks the
    reader has not had yet (``since=K`` starts after chunk K; default: with the
    newest chunk); for other data it is the latest value and ``lost`` counts the
    publications skipped while the reader was busy.  When the instance is
    unloaded (or killed) the stream sends ``unload`` and ends.

    In the standard form (``Accept: text/event-stream``) each event's id is the
    newest item it holds (numbered data) or the publication's number: an
    EventSource that reconnects resumes after the chunks it had (its
    ``Last-Event-ID`` wins over the ``since`` of the URL it opens again);
    after ``unload`` it gets 204 and stops.
    """
    last_event = request.headers.get("Last-Event-ID")
    if last_event == FINAL_ID:
        return web.Response(status=204, headers=SERVER_HEADER)
    name, port = _port(request)
    if not isinstance(port, OutPortRuntime):
        raise BadQuery(f"{name} is an in port: watch its remote out port instead")
    element = _element(request, port)
    since = _since(request)
    if port.spec.multiple:
        # Refused now, as an HTTP error, not after the stream has started: a multiple port
        # is watched one element at a time, and the element must exist.
        if element is None:
            raise BadQuery(f"port {name} is multiple: watch one element with name=")
        port.read(element)
    # Refused now, as an HTTP error, not after the stream has started: data withdrawn (503), a silent
    # component host (504), a remote window this gateway cannot hold (429).
    port.read(element)
    if (last_event is not None and last_event.isascii() and last_event.isdigit()
            and isinstance(port.read(element), Incremental)):
        # An EventSource resuming where it was: it opens the same URL again, so its since= is the
        # first one, and the id of the last event it had is the newer truth.
        since = parse_since(last_event)
    elif since is not None and port.version:
        _require_incremental(port, port.read(element))
    shutdown = request.app[SHUTDOWN]
    stall = request.app[CONFIG].connections.keep_alive or None
    frames = request.app[WATCH_FRAMES]
    wakes = request.app[WATCH_WAKES]
    unloaded = request.app[UNLOADS].of(port.owner)
    stream = event_stream(request)
    frames.joined(port)
    try:
        await stream.prepare(request)
        delivered = 0  # the port version the reader has
        last_index = since
        while not shutdown.is_set() and not unloaded.done():
            # Withdrawn data (a sensor down) is not current: the watcher waits for the next publication.
            stuck = False
            if port.version > delivered and port.withdrawn is None:
                try:
                    frame, delivered, last_index = _watch_frame(frames, name, port, element, delivered, last_index)
                except (PortUnavailable, RemoteUnreachable, OverBudget):
                    stuck = True  # not current after all (a silent component host...): as withdrawn data
                else:
                    if stream.standard:
                        frame = (event_id(delivered if last_index is None else last_index) + frame[0], *frame[1:])
                    await _write_event(request, stream, frame, stall)
                    continue
            # With every other watcher of the port: woken by a publication, the end, or a ping.
            await wakes.wait(port)
            if ((stuck or port.version == delivered or port.withdrawn is not None) and not shutdown.is_set()
                    and not unloaded.done()):
                await stream.write(PING)
        if unloaded.done():
            end = format_event("unload", orjson.dumps(port.owner.instance))
            await stream.write(event_id(FINAL_ID) + end if stream.standard else end)
    except ConnectionError:
        pass  # the reader went away
    finally:
        frames.left(port)
    with contextlib.suppress(ConnectionError):
        await stream.write_eof()
    return stream
