"""The 2014 dedicated-socket server: ``Read Port - Index <k>`` answered from the chunk window."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core import Budgets, HostSettings, Ledger

from ._line_server import LastReply, LineServer
from ._socket_wire import encode_reply, encode_state_reply, parse_request, reply_size
from ._window import ChunkWindow, WindowRead

__all__ = ["DedicatedSocketServer", "DEFAULT_PORT"]

#: The dedicated socket's port unless told otherwise (the host's default).
DEFAULT_PORT = HostSettings().audio_socket_port
_NO_CHUNKS = WindowRead(left=np.zeros((0, 0), np.int32), right=np.zeros((0, 0), np.int32),
                        positions=np.zeros(0), first_index=1, last_index=0, lost=0)


class _ChunkConversation:
    """One client of the 2014 protocol: each request line gets the chunks after its index."""

    def __init__(self, server: DedicatedSocketServer) -> None:
        self._server = server

    def answer(self, line: bytes) -> bytearray:
        return self._server.reply_to(parse_request(line))


class DedicatedSocketServer(LineServer):
    """Answer ``Read Port - Index <k>`` requests from the current chunk window.

    Args:
        window: Returns the window to serve (None while no capture has started:
            clients then get zero chunks and index 0).
        host: The address to bind (``0.0.0.0`` for every interface).
        port: The TCP port; 0 picks a free one (read :attr:`port` after :meth:`start`).
        with_positions: Append the head positions (the merged component's format).
        token: When set, every client must first send ``Token <token>``.
        budgets: The bounds on clients and their unsent replies (see :class:`LineServer`).
        ledger: The unsent replies of every dedicated socket of the host.
    """

    def __init__(self, window: Callable[[], ChunkWindow | None], *, host: str = HostSettings().audio_socket_host,
                 port: int = DEFAULT_PORT, with_positions: bool = False, token: str | None = None,
                 budgets: Budgets = HostSettings().budgets, ledger: Ledger | None = None) -> None:
        super().__init__(lambda: _ChunkConversation(self), host=host, port=port, token=token, budgets=budgets,
                         ledger=ledger)
        self._window = window
        self.with_positions = with_positions
        self._last = LastReply()

    def reply_to(self, index: int) -> bytearray:
        """The reply to a request for the chunks after *index*, in a buffer nothing writes afterwards.

        The transport may hold the reply while the client drains it, long after
        the window has moved on: it shares no memory with the window, and is
        never changed once made (so the readers of one publication share it).
        A reply is at most :attr:`client_bytes`: when the chunks after *index* are
        more, it carries the newest that fit, and the client counts the others lost
        (as it counts those the window no longer holds).
        """
        window = self._window()
        if window is None:
            return encode_reply(_NO_CHUNKS, with_positions=self.with_positions)
        state = window.state
        per_chunk = reply_size(1, window.frames_per_chunk, with_positions=self.with_positions) - reply_size(
            0, window.frames_per_chunk)
        fitting = max(0, (self.client_bytes - reply_size(0, window.frames_per_chunk)) // per_chunk)
        count, _ = state.count_since(index, fitting)  # the reply carries the newest *count* chunks
        return self._last.get(state, count, lambda: encode_state_reply(state, index, with_positions=self.with_positions,
                                                                        limit=fitting))
