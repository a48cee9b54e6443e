"""The 2015 dedicated-socket server: ``Read Port - N <n> - nfr <i>`` answered from the newest ``Audio`` snapshot."""

from __future__ import annotations

from collections.abc import Callable

import dataclasses

from ..audio import CLOSE, DEFAULT_PORT, LastReply, LineServer
from ..core import Budgets, HostSettings, Ledger
from ._history import AudioSnapshot
from ._socket_wire import FrameRequest, encode_snapshot_reply, frame_reply_size, parse_frame_request

__all__ = ["FrameSocketServer"]


class _FrameConversation:
    """One client of the 2015 protocol."""

    def __init__(self, server: FrameSocketServer) -> None:
        self._server = server

    def answer(self, line: bytes) -> bytes | bytearray | None:
        request = parse_frame_request(line)
        if request is None:
            return CLOSE
        return self._server.reply_to(request)


class FrameSocketServer(LineServer):
    """Serve the frame-indexed 2015 protocol to any number of clients.

    Args:
        snapshot: Returns the port's newest publication.
        host: The address to bind (``0.0.0.0`` for every interface).
        port: The TCP port; 0 picks a free one (read :attr:`port` after :meth:`start`).
        token: When set, every client must first send ``Token <token>``.
        budgets: The bounds on clients and their unsent replies (see :class:`LineServer`).
        ledger: The unsent replies of every dedicated socket of the host.
    """

    def __init__(self, snapshot: Callable[[], AudioSnapshot], *, host: str = HostSettings().audio_socket_host,
                 port: int = DEFAULT_PORT, token: str | None = None, budgets: Budgets = HostSettings().budgets,
                 ledger: Ledger | None = None) -> None:
        super().__init__(lambda: _FrameConversation(self), host=host, port=port, token=token, budgets=budgets,
                         ledger=ledger)
        self._snapshot = snapshot
        self._last = LastReply()

    def reply_to(self, request: FrameRequest) -> bytearray:
        """The reply to *request*, copied once from the snapshot's chunks, in a buffer nothing writes afterwards.

        The transport may hold the reply while the client drains it: it shares no memory with the
        snapshot, and is never changed once made.  Before the first acquisition the port is
        ``AudioSnapshot.empty()``: no frames, and the client keeps its place.  A reply is at most
        :attr:`client_bytes`: a larger ``N`` gets fewer frames, and ``next`` says where to go on
        (nothing is lost).
        """
        per_frame = frame_reply_size(1) - frame_reply_size(0)
        fitting = max(0, (self.client_bytes - frame_reply_size(0)) // per_frame)
        if request.frames > fitting:
            request = dataclasses.replace(request, frames=fitting)
        snapshot = self._snapshot()
        return self._last.get(snapshot, snapshot.placed(request.next_frame, request.frames),
                              lambda: encode_snapshot_reply(snapshot, request.next_frame, request.frames))
