"""One viewer of the live view: its subscriptions, and what waits to be sent to it, within its budget.

A viewer (Foxglove, Lichtblick, a program) subscribes to channels and reads what the server
sends.  What it has not read yet waits here, in its outbox, and counts against its budget
(``--max-viewer-bytes``) together with what its socket's buffer holds:

* a port is a value that changes: a newer message of a channel replaces the one still waiting,
  in its place in line (a viewer slower than the cameras sees their latest pictures at its own
  pace, never a growing queue of old ones);
* audio is a stream: each chunk waits for its turn, none replaced;
* the server's own messages (advertisements, status) always wait their turn.

A viewer whose unsent bytes pass its budget (one that does not read while it listens to audio,
or falls ever further behind) is dropped: its connection is cut, and the log says so once, in
a rate-limited line.  Nothing it holds outlives it.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import struct
from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import orjson
from aiohttp import web

from ..components.core import ThrottledLog
from ..components.core.runtime import size_text

__all__ = ["Viewer", "Outgoing", "MESSAGE_DATA"]

#: The binary opcode of a channel's message (``messageData``): opcode, subscription id, log time, payload.
MESSAGE_DATA = 1
_HEAD = struct.Struct("<BIQ")

#: ``status`` levels of the protocol.
INFO, WARNING, ERROR = 0, 1, 2


class Outgoing:
    """A message waiting for one viewer: a text message, or a channel message's header and shared payload.

    Attributes:
        text: The JSON text of a server message (None for a channel message).
        head: The 13-byte header of a channel message (opcode, this viewer's subscription, log time).
        payload: The encoded message, shared by every viewer it is sent to.
        size: The bytes it holds for this viewer.
    """

    __slots__ = ("text", "head", "payload", "size")

    def __init__(self, text: str | None, head: bytes = b"", payload: bytes = b"") -> None:
        self.text, self.head, self.payload = text, head, payload
        self.size = len(text) if text is not None else len(head) + len(payload)


class Viewer:
    """A connected viewer: its socket, its subscriptions and its outbox.

    Args:
        socket: The prepared WebSocket.
        transport: Its connection (whose buffer's unsent bytes count against the budget: the
            socket's writer hands it a whole message at once).
        budget: The most bytes it may hold unsent (``--max-viewer-bytes``).
        name: How the log names it (its address).
        log: The view's rate-limited log.
        on_dropped: Called once when the viewer is dropped for its budget, before its connection is cut.
    """

    def __init__(self, socket: web.WebSocketResponse, transport: asyncio.Transport, budget: int, name: str,
                 log: ThrottledLog, on_dropped: Callable[[Viewer], None]) -> None:
        self.socket, self.name, self.budget = socket, name, budget
        self._transport = transport
        self._log, self._on_dropped = log, on_dropped
        #: Subscription id -> channel id, and the reverse (one subscription a channel, as the protocol says).
        self.subscriptions: dict[int, int] = {}
        self.channels: dict[int, int] = {}
        # Keys: ("c", channel id) for a channel's latest message, an int for everything else.
        self._outbox: OrderedDict[Any, Outgoing] = OrderedDict()
        self._order = itertools.count()
        self.unsent = 0  # bytes in the outbox
        self._ready = asyncio.Event()
        self.dropped = False
        self._writer = asyncio.create_task(self._write(), name=f"foxglove viewer {name}")

    # -- what the server sends ------------------------------------------------------------------

    def send_json(self, message: dict[str, Any]) -> None:
        """Queue a server message (``serverInfo``, ``advertise``, ``status``...)."""
        self._queue(next(self._order), Outgoing(orjson.dumps(message).decode()))

    def status(self, level: int, message: str) -> None:
        """Tell the viewer something (Foxglove shows it among the connection's problems)."""
        self.send_json({"op": "status", "level": level, "message": message})

    def send_data(self, channel: int, log_time: int, payload: bytes, latest_only: bool) -> None:
        """Queue a message of *channel* (if this viewer subscribes to it).

        Args:
            channel: The channel's id.
            log_time: Nanoseconds since the epoch.
            payload: The encoded message.
            latest_only: Whether a newer message replaces this one while it waits.
        """
        subscription = self.channels.get(channel)
        if subscription is None:
            return
        outgoing = Outgoing(None, _HEAD.pack(MESSAGE_DATA, subscription, log_time), payload)
        self._queue(("c", channel) if latest_only else next(self._order), outgoing)

    def forget_channel(self, channel: int) -> None:
        """The channel is gone: its subscription and its waiting message with it."""
        subscription = self.channels.pop(channel, None)
        if subscription is not None:
            del self.subscriptions[subscription]
        waiting = self._outbox.pop(("c", channel), None)
        if waiting is not None:
            self.unsent -= waiting.size

    def _queue(self, key: Any, outgoing: Outgoing) -> None:
        if self.dropped:
            return
        replaced = self._outbox.get(key)
        if replaced is not None:
            self.unsent -= replaced.size
        self._outbox[key] = outgoing  # a replacement keeps its predecessor's place in line
        self.unsent += outgoing.size
        held = self.unsent + self._transport.get_write_buffer_size()
        if held > self.budget:
            self.drop(f"it holds {size_text(held)} unsent, more than the {size_text(self.budget)} of "
                      "--max-viewer-bytes (a viewer that does not read, or falls ever further behind)")
            return
        self._ready.set()

    async def _write(self) -> None:
        socket = self.socket
        try:
            while True:
                await self._ready.wait()
                if not self._outbox:
                    self._ready.clear()
                    continue
                _, outgoing = self._outbox.popitem(last=False)
                self.unsent -= outgoing.size
                # The socket's writer waits while the connection's buffer is full: a viewer that
                # does not read keeps this task here, and its messages wait in the outbox.
                if outgoing.text is not None:
                    await socket.send_str(outgoing.text)
                else:
                    await socket.send_bytes(outgoing.head + outgoing.payload)
        except (ConnectionError, RuntimeError) as exc:
            # The viewer went away (reset, closed): its reader sees the end too.
            self._log.log(logging.DEBUG, "Foxglove viewer %s: sending ended: %s", self.name, exc)

    # -- the end ----------------------------------------------------------------------------------

    def drop(self, why: str) -> None:
        """Cut the viewer's connection, say why in the log (rate-limited), free what it holds."""
        if self.dropped:
            return
        self.dropped = True
        self._log.info("Foxglove viewer %s dropped: %s", self.name, why)
        self._release()
        self._on_dropped(self)
        # It would not read a closing handshake: the connection is cut, its reader sees the end.
        self._transport.abort()

    async def close(self, goodbye: float = 0.0) -> None:
        """Stop sending and free what the viewer holds.

        Args:
            goodbye: Seconds the viewer has to take a closing message (the gateway stops); 0 when its
                connection has ended already.  One that does not take it in time is cut.
        """
        self._release()
        self._writer.cancel()
        await asyncio.gather(self._writer, return_exceptions=True)
        if goodbye > 0 and not self.socket.closed:
            try:
                async with asyncio.timeout(goodbye):    # not wait_for: on 3.11 it can lose a cancellation
                    await self.socket.close(code=1001, message=b"the gateway stops")
            except (TimeoutError, ConnectionError):
                self._transport.abort()

    def _release(self) -> None:
        self._outbox.clear()
        self.unsent = 0
        self.subscriptions.clear()
        self.channels.clear()
