"""The live view's WebSocket server: the Foxglove WebSocket protocol, behind the gateway's door.

Foxglove, Lichtblick and the ``@foxglove/ws-protocol`` client connect with a WebSocket
offering one of two names for the same protocol: ``foxglove.websocket.v1`` (its
specification's name, offered by ``@foxglove/ws-protocol`` and by Lichtblick before its
pull request 819) or ``foxglove.sdk.v1`` (the Foxglove SDK's name, which foxglove_bridge
answers since 3.2 and the newer viewers offer).  The server takes the first of the viewer's
names: both are served alike.

A connection is admitted as an HTTP request is (decision 0036):

1. the door (:meth:`Door.decide`): the Host and Origin rules, ``--allowed-host`` and
   ``--allow-origin``, then the token (``--token``), carried as ``Authorization: Bearer``
   by a program, or in the URL (``ws://host:8765/?token=...``) by a viewer, which cannot
   set a header on a WebSocket;
2. the count of viewers (``--max-viewers``): one more is refused 429, naming the flag;
3. a Foxglove subprotocol among those offered (else 400).

Then the server sends ``serverInfo`` and the advertisement of every channel, and streams
each channel's messages to the viewers that subscribe to it, each viewer within its send
budget (``_foxglove_viewer``).  A refusal, a reset connection or a viewer's malformed
message is the client's doing: a DEBUG line at most, rate-limited.
"""

from __future__ import annotations

import asyncio
import base64
import itertools
import logging
import time
from collections.abc import Iterable
from typing import Any

import orjson
from aiohttp import WSMsgType, web

from ..components.core import ThrottledLog
from ._access import target_authority
from ._door import Door, Refusal, repeated_fields
from ._foxglove_viewer import ERROR, WARNING, Viewer
from ._parameters import LIVE_VIEW
from ._replies import SERVER_HEADER, json_reply

__all__ = ["LiveViewServer", "LiveChannel", "SUBPROTOCOLS"]

log = logging.getLogger("aiogenomix.gateway._foxglove")

#: The names of the Foxglove WebSocket protocol the server answers to, in no order of preference.
SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")
#: The largest message a viewer may send (a subscription to a few hundred channels is a few kilobytes).
_MAX_VIEWER_MESSAGE = 1 << 20
#: Seconds a viewer has to take the server's closing message when the gateway stops (one that does
#: not read would never take it).
_STOP_GRACE = 1.0


class LiveChannel:
    """A channel of the view, as the protocol advertises it.

    Args:
        id: Its number, unique in the server's life.
        topic: Its topic (``/kemar/currentState``).
        encoding: How its messages are encoded (``protobuf``, ``json``).
        schema_name: The name of its schema (``foxglove.RawImage``).
        schema_encoding: The schema's own encoding (``protobuf``, ``jsonschema``).
        schema: The schema as it travels: a protobuf FileDescriptorSet in base64, a JSON Schema as text.
        latest_only: Whether a newer message replaces an unsent one (every port but audio).
    """

    def __init__(self, id: int, topic: str, encoding: str, schema_name: str, schema_encoding: str, schema: str,
                 latest_only: bool = True) -> None:
        self.id, self.topic, self.latest_only = id, topic, latest_only
        self.advertisement = {"id": id, "topic": topic, "encoding": encoding, "schemaName": schema_name,
                              "schemaEncoding": schema_encoding, "schema": schema}
        #: The viewers subscribed to it.
        self.viewers: set[Viewer] = set()
        #: Set when a viewer subscribes: its follower sends the current data at once.
        self.subscribed = asyncio.Event()

    @property
    def watched(self) -> bool:
        """Whether any viewer subscribes (else nothing is read or encoded for it)."""
        return bool(self.viewers)


def protobuf_schema(data: bytes) -> str:
    """A protobuf schema (a serialized FileDescriptorSet) as an advertisement carries it."""
    return base64.b64encode(data).decode()


class LiveViewServer:
    """The WebSocket server of the live view.

    Args:
        door: The gateway's door (its Host and Origin rules and its token).
        name: The server's name, shown by the viewers.
        max_viewers: How many viewers may be connected at once (``--max-viewers``).
        viewer_bytes: The most bytes one viewer may hold unsent (``--max-viewer-bytes``).
    """

    def __init__(self, door: Door, name: str, max_viewers: int, viewer_bytes: int) -> None:
        self.door, self.name = door, name
        self.max_viewers, self.viewer_bytes = max_viewers, viewer_bytes
        self.channels: dict[int, LiveChannel] = {}
        self.viewers: set[Viewer] = set()
        self._admitting = 0  # viewers counted but not yet connected
        self._ids = itertools.count(1)
        self._session = str(time.time_ns())
        self._log = ThrottledLog(log)
        self._runner: web.AppRunner | None = None
        self.port = 0

    # -- the server's life --------------------------------------------------------------------------

    async def start(self, address: str, port: int) -> None:
        """Listen on *address*:*port* (0: a free port, then in :attr:`port`).

        Raises:
            OSError: when the address cannot be listened on.
        """
        app = web.Application(client_max_size=_MAX_VIEWER_MESSAGE)
        app.router.add_route("*", "/{tail:.*}", self._connect)
        # No access log: a viewer's connection is not a request worth a line.  What aiohttp itself
        # would log is a malformed request's refusal: the client's doing, one DEBUG line.
        runner = web.AppRunner(app, access_log=None, handle_signals=False, logger=_HTTP_LOG,
                               shutdown_timeout=_STOP_GRACE)
        await runner.setup()
        site = web.TCPSite(runner, address, port)
        try:
            await site.start()
        except BaseException:
            await runner.cleanup()
            raise
        self._runner = runner
        self.port = int(runner.addresses[0][1]) if runner.addresses else port

    async def stop(self) -> None:
        """Close every viewer's connection, within a second, and stop listening (idempotent)."""
        runner, self._runner = self._runner, None
        await asyncio.gather(*(viewer.close(goodbye=_STOP_GRACE) for viewer in list(self.viewers)))
        if runner is not None:
            await runner.cleanup()

    # -- channels ---------------------------------------------------------------------------------

    def add_channel(self, topic: str, encoding: str, schema_name: str, schema_encoding: str, schema: str,
                    latest_only: bool = True) -> LiveChannel:
        """A new channel, advertised to every viewer at once."""
        channel = LiveChannel(next(self._ids), topic, encoding, schema_name, schema_encoding, schema, latest_only)
        self.channels[channel.id] = channel
        for viewer in self.viewers:
            viewer.send_json({"op": "advertise", "channels": [channel.advertisement]})
        return channel

    def remove_channels(self, channels: Iterable[LiveChannel]) -> None:
        """Withdraw *channels*: their subscriptions end, and every viewer is told."""
        ids = [c.id for c in channels if self.channels.pop(c.id, None) is not None]
        if not ids:
            return
        for viewer in self.viewers:
            for channel_id in ids:
                viewer.forget_channel(channel_id)
            viewer.send_json({"op": "unadvertise", "channelIds": ids})

    def publish(self, channel: LiveChannel, log_time: int, payload: bytes) -> None:
        """Send one message of *channel* (log time in nanoseconds) to each viewer subscribed to it."""
        for viewer in channel.viewers:
            viewer.send_data(channel.id, log_time, payload, channel.latest_only)

    # -- a viewer connects ------------------------------------------------------------------------

    async def _connect(self, request: web.Request) -> web.StreamResponse:
        """Admit a viewer (or refuse it, as the door and the budgets say), then serve it until it leaves."""
        refusal = self._refusal(request)
        if refusal is not None:
            self._log.log(logging.DEBUG, "Foxglove view refused %s: %s", _peer(request), refusal.body["message"])
            return json_reply(refusal.body, status=refusal.status)
        offered = [p.strip() for p in request.headers.get("Sec-WebSocket-Protocol", "").split(",")]
        protocol = next(p for p in offered if p in SUBPROTOCOLS)  # _refusal saw one
        self._admitting += 1
        try:
            socket = web.WebSocketResponse(protocols=(protocol,), compress=False, max_msg_size=_MAX_VIEWER_MESSAGE,
                                           autoclose=True, autoping=True)
            socket.headers.update(SERVER_HEADER)
            await socket.prepare(request)
        except ConnectionError as exc:  # gone while upgrading
            self._log.log(logging.DEBUG, "Foxglove viewer %s left while connecting: %s", _peer(request), exc)
            return web.Response()  # (nobody to send it to: aiohttp lets it go)
        except web.HTTPException as exc:  # a handshake aiohttp refuses (a bad Sec-WebSocket-Key)
            return json_reply({"ex": "::genomix::http", "message": exc.reason}, status=exc.status)
        finally:
            self._admitting -= 1
        transport = request.transport
        if transport is None:  # gone while upgrading
            return socket
        viewer = Viewer(socket, transport, self.viewer_bytes, _peer(request), self._log, self._leave)
        self.viewers.add(viewer)
        self._log.log(logging.DEBUG, "Foxglove viewer %s connected (%s)", viewer.name, protocol)
        try:
            viewer.send_json({"op": "serverInfo", "name": self.name, "capabilities": [], "metadata": {},
                              "sessionId": self._session})
            if self.channels:
                viewer.send_json({"op": "advertise", "channels": [c.advertisement for c in self.channels.values()]})
            await self._read(viewer)
        finally:
            self._leave(viewer)
            await viewer.close()
        return socket

    def _refusal(self, request: web.Request) -> Refusal | None:
        """Why a connection is refused (the door, the method, the upgrade, the count, the subprotocol), or None."""
        headers = request.headers
        names = [name for name, _ in request.query.items()] if request.query_string else ()
        tokens = request.query.getall("token", ()) if request.query_string else ()
        # The host a request names: an absolute-form target's authority, whatever Host says (as on HTTP).
        target = request.raw_path
        authority = target_authority(target) if target[:1] != "/" else None
        verdict = self.door.decide("GET", LIVE_VIEW, names, headers, url_token=tokens[0] if tokens else None,
                                   authority=authority, repeated=repeated_fields(headers))
        if isinstance(verdict, Refusal):
            return verdict
        if request.method != "GET" or headers.get("Upgrade", "").lower() != "websocket":
            return Refusal(426, {"ex": "::genomix::http", "message": (
                "this is the gateway's live view: open it in Foxglove or Lichtblick (open a connection, "
                f"Foxglove WebSocket, ws://{headers.get('Host', 'this-address')}/)")})
        if len(self.viewers) + self._admitting >= self.max_viewers:
            return Refusal(429, {"ex": "::genomix::too_many_viewers", "message": (
                f"{len(self.viewers)} viewers are connected, the most this gateway serves (--max-viewers "
                f"{self.max_viewers}): close one, or ask the operator for more")})
        offered = {p.strip() for p in headers.get("Sec-WebSocket-Protocol", "").split(",")}
        if offered.isdisjoint(SUBPROTOCOLS):
            return Refusal(400, {"ex": "::genomix::http", "message": (
                "the live view speaks the Foxglove WebSocket protocol: offer the subprotocol "
                f"{' or '.join(SUBPROTOCOLS)}")})
        return None

    async def _read(self, viewer: Viewer) -> None:
        """Take the viewer's messages (subscriptions) until it leaves or is dropped."""
        async for message in viewer.socket:
            if message.type == WSMsgType.TEXT:
                self._handle(viewer, message.data)
            elif message.type == WSMsgType.BINARY:
                viewer.status(WARNING, "this server takes no client messages (no clientPublish, no services)")
            elif message.type == WSMsgType.ERROR:
                self._log.log(logging.DEBUG, "Foxglove viewer %s: %s", viewer.name, viewer.socket.exception())
                break

    def _handle(self, viewer: Viewer, text: str) -> None:
        """One JSON message of a viewer: a subscription, an unsubscription, or something this server does not do."""
        try:
            message = orjson.loads(text)
            op = message["op"]
            if op == "subscribe":
                for item in message["subscriptions"]:
                    self._subscribe(viewer, _whole(item["id"]), _whole(item["channelId"]))
            elif op == "unsubscribe":
                for subscription in message["subscriptionIds"]:
                    self._unsubscribe(viewer, _whole(subscription))
            else:
                viewer.status(WARNING, f"this server does not do {str(op)[:40]!r}")
        except (orjson.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
            viewer.status(ERROR, f"not a message of the Foxglove WebSocket protocol: {type(exc).__name__} {exc}")

    def _subscribe(self, viewer: Viewer, subscription: int, channel_id: int) -> None:
        channel = self.channels.get(channel_id)
        if channel is None:
            viewer.status(ERROR, f"no channel {channel_id} (it may have been withdrawn)")
        elif subscription in viewer.subscriptions:
            viewer.status(ERROR, f"subscription {subscription} is already in use")
        elif channel_id in viewer.channels:
            viewer.status(ERROR, f"channel {channel_id} is already subscribed to")
        else:
            viewer.subscriptions[subscription] = channel_id
            viewer.channels[channel_id] = subscription
            channel.viewers.add(viewer)
            channel.subscribed.set()

    def _unsubscribe(self, viewer: Viewer, subscription: int) -> None:
        channel_id = viewer.subscriptions.pop(subscription, None)
        if channel_id is None:
            viewer.status(WARNING, f"no subscription {subscription}")
            return
        viewer.forget_channel(channel_id)
        channel = self.channels.get(channel_id)
        if channel is not None:
            channel.viewers.discard(viewer)

    # -- a viewer leaves ------------------------------------------------------------------------

    def _leave(self, viewer: Viewer) -> None:
        self.viewers.discard(viewer)
        for channel_id in viewer.channels:
            channel = self.channels.get(channel_id)
            if channel is not None:
                channel.viewers.discard(viewer)


class _AsClientFault(logging.Filter):
    """Turns what aiohttp logs about a malformed request (at ERROR, with a traceback) into a rate-limited DEBUG line."""

    def __init__(self, log: ThrottledLog) -> None:
        super().__init__()
        self._log = log

    def filter(self, record: logging.LogRecord) -> bool:
        fault = record.exc_info[1] if record.exc_info else None
        self._log.log(logging.DEBUG, "Foxglove view: %s: %s", record.getMessage(), fault)
        return False


#: The logger the view's aiohttp server reports to: only ever about a request it could not parse.
_HTTP_LOG = logging.getLogger(f"{log.name}.http")
_HTTP_LOG.addFilter(_AsClientFault(ThrottledLog(log)))


def _whole(value: Any) -> int:
    """A protocol id: a whole number that fits 32 bits (a bool is no number here)."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2**32:
        raise ValueError(f"{value!r} is no id (a whole number from 0 to 2^32 - 1)")
    return value


def _peer(request: web.Request) -> str:
    """The viewer's address, as the log names it."""
    peer = request.transport.get_extra_info("peername") if request.transport is not None else None
    return f"{peer[0]}:{peer[1]}" if isinstance(peer, tuple) and len(peer) >= 2 else "a viewer"

