"""An asyncio driver for an Elmo Harmonica drive over any python-can bus."""

from __future__ import annotations

import asyncio
import collections
import contextlib
import logging
from typing import Any
from types import TracebackType
from collections.abc import Callable

import can

from ._codec import (
    NMT_COB_ID,
    SDO_ABORT_CODES,
    CobIds,
    CodecError,
    CommandKind,
    Emergency,
    InterpreterReply,
    InterpreterRequest,
    NmtCommand,
    NmtState,
    SdoFrame,
    SdoKind,
    StatusRegister,
    decode_emcy,
    decode_sdo,
    encode_nmt,
    encode_sdo_download,
    encode_sdo_upload_request,
    error_code_meaning,
)
from ..core import Clock
from ._errors import BusError, DriveCommandError, DriveTimeout, SdoAbortError

__all__ = ["HarmonicaDriver", "EmergencyListener"]

_log = logging.getLogger(__name__)

#: Called on the event loop with every EMCY frame the drive sends.
EmergencyListener = Callable[[Emergency], None]

# How long the Notifier's reader thread blocks in recv(); it bounds how long
# close() waits for that thread, not the reply latency.
_READER_POLL = 0.02


class HarmonicaDriver:
    """Talks to one Elmo Harmonica drive: binary interpreter, expedited SDO, NMT and EMCY.

    Each request waits for its own reply: replies are matched to requests by
    (mnemonic, index), with one request in flight per key, a future per request
    and a timeout.  Requests on different keys run concurrently.  Emergency frames
    are decoded, kept in :attr:`emergencies` and passed to listeners.

    Use it as an async context manager, or call :meth:`start` then :meth:`aclose`::

        async with HarmonicaDriver.open("virtual", "kemar") as drive:
            await drive.nmt(NmtCommand.START)
            position = await drive.query("PX")

    Args:
        bus: An open python-can bus.
        node_id: The drive's CANopen node id.
        timeout: Seconds to wait for each reply (real time: bus latency does not
            follow a simulated clock).
        clock: The runtime clock of a simulation: a reply is awaited holding it
            (:meth:`Clock.holding`), so simulated time stands still while the drive
            answers from its thread.  None for a drive on a real bus.
        expect_set_echo: Wait for the drive's echo of set commands (the drives in
            the field echo them; without echo a set is fire-and-forget).
        own_bus: Shut the bus down on close.
    """

    def __init__(
        self,
        bus: can.BusABC,
        *,
        node_id: int = 0x7F,
        timeout: float = 0.5,
        expect_set_echo: bool = True,
        own_bus: bool = False,
        clock: Clock | None = None,
    ) -> None:
        self.bus = bus
        self._clock = clock
        self.cob = CobIds(node_id)
        self.timeout = timeout
        self.expect_set_echo = expect_set_echo
        self._own_bus = own_bus
        self._notifier: can.Notifier | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._pending: dict[tuple[str, int], asyncio.Future[InterpreterReply]] = {}
        self._key_locks: dict[tuple[str, int], asyncio.Lock] = {}
        self._sdo_lock = asyncio.Lock()
        self._sdo_pending: asyncio.Future[SdoFrame] | None = None
        self._listeners: list[EmergencyListener] = []
        self._closed = False
        #: The most recent EMCY frames, oldest first.
        self.emergencies: collections.deque[Emergency] = collections.deque(maxlen=32)
        #: The last fault EMCY not followed by a reset EMCY or :meth:`clear_emergency`.
        self.latched_emergency: Emergency | None = None
        #: The NMT state from the drive's last heartbeat or boot-up frame.
        self.nmt_state: NmtState | None = None
        #: Frames from the drive that matched no request (late replies, garbage).
        self.unmatched_frames = 0

    @classmethod
    def open(cls, interface: str = "virtual", channel: str = "kemar", **kwargs: object) -> HarmonicaDriver:
        """Open a python-can bus and return a driver that owns it (not yet started).

        Args:
            interface: python-can interface (``virtual``, ``socketcan``, ``pcan``...).
            channel: Bus channel (``can0``, a virtual channel name...).
            **kwargs: Keyword arguments of :class:`HarmonicaDriver`.

        Raises:
            BusError: python-can could not open the bus.
        """
        try:
            bus = can.Bus(interface=interface, channel=channel)
        except (can.CanError, OSError, ValueError, ImportError) as exc:
            raise BusError(f"cannot open CAN bus {interface}:{channel}: {exc}") from exc
        return cls(bus, own_bus=True, **kwargs)  # type: ignore[arg-type]

    # ------------------------------------------------------------------ lifecycle

    def start(self) -> None:
        """Start receiving on the running event loop (idempotent)."""
        if self._closed:
            raise BusError("the driver is closed")
        if self._notifier is None:
            self._loop = asyncio.get_running_loop()
            self._notifier = can.Notifier(self.bus, [self._on_message], timeout=_READER_POLL, loop=self._loop)

    async def aclose(self) -> None:
        """Stop receiving, fail pending requests and release the bus (idempotent)."""
        if self._closed:
            return
        self._closed = True
        notifier, self._notifier = self._notifier, None
        if notifier is not None:
            # Joining the reader thread blocks for up to _READER_POLL: do it off the loop.
            await asyncio.to_thread(notifier.stop)
        closed = BusError("the driver was closed")
        for future in self._pending.values():
            if not future.done():
                future.set_exception(closed)
        if self._sdo_pending is not None and not self._sdo_pending.done():
            self._sdo_pending.set_exception(closed)
        if self._own_bus:
            self.bus.shutdown()

    @property
    def closed(self) -> bool:
        """Whether :meth:`aclose` was called."""
        return self._closed

    async def __aenter__(self) -> HarmonicaDriver:
        self.start()
        return self

    async def __aexit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        await self.aclose()

    # ------------------------------------------------------------------ emergencies

    def add_emergency_listener(self, listener: EmergencyListener) -> None:
        """Call *listener* (on the event loop) with every EMCY frame."""
        self._listeners.append(listener)

    def remove_emergency_listener(self, listener: EmergencyListener) -> None:
        """Stop calling *listener*."""
        self._listeners.remove(listener)

    def clear_emergency(self) -> None:
        """Forget the latched emergency (after the host has cleared the fault)."""
        self.latched_emergency = None

    # ------------------------------------------------------------------ binary interpreter

    async def set(self, mnemonic: str, value: int | float, index: int = 0) -> int | float:
        """Set ``mnemonic[index] = value`` and return the drive's echo.

        The Python type of *value* chooses the wire type (int32 or float32).

        Raises:
            DriveCommandError: The drive refused the command (its EC code is in the error).
            DriveTimeout: No reply in time.
            BusError: The bus refused the frame or the driver is closed.
        """
        request = InterpreterRequest(CommandKind.SET, mnemonic.upper(), index, value)
        if not self.expect_set_echo:
            self._send(self.cob.interpreter_request, request.encode())
            return value
        reply = await self._transact(request)
        return value if reply.value is None else reply.value

    async def query(self, mnemonic: str, index: int = 0) -> int | float:
        """Return the value of ``mnemonic[index]`` (int or float, as the drive sends it).

        Raises:
            DriveCommandError: The drive refused the query.
            DriveTimeout: No reply in time.
            BusError: The bus refused the frame or the driver is closed.
        """
        reply = await self._transact(InterpreterRequest(CommandKind.QUERY, mnemonic.upper(), index))
        assert reply.value is not None
        return reply.value

    async def query_int(self, mnemonic: str, index: int = 0) -> int:
        """Like :meth:`query`, for integer registers."""
        return int(await self.query(mnemonic, index))

    async def execute(self, mnemonic: str, index: int = 0) -> None:
        """Execute a command such as ``BG`` or ``ST`` and wait for its acknowledgement.

        Raises:
            DriveCommandError: The drive refused it (e.g. EC 58 when the motor is off).
            DriveTimeout: No reply in time.
            BusError: The bus refused the frame or the driver is closed.
        """
        await self._transact(InterpreterRequest(CommandKind.EXECUTE, mnemonic.upper(), index))

    async def status(self) -> StatusRegister:
        """Query and decode the status register SR."""
        return StatusRegister(await self.query_int("SR"))

    async def _transact(self, request: InterpreterRequest) -> InterpreterReply:
        key = (request.mnemonic, request.index)
        lock = self._key_locks.get(key)
        if lock is None:
            lock = self._key_locks[key] = asyncio.Lock()
        async with lock:
            future = self._new_future()
            self._pending[key] = future
            try:
                self._send(self.cob.interpreter_request, request.encode())
                reply = await self._wait(future, f"{request.kind.value} {_name(request.mnemonic, request.index)}")
            finally:
                if self._pending.get(key) is future:
                    del self._pending[key]
        if reply.error_code is not None:
            raise DriveCommandError(reply.mnemonic, reply.index, reply.error_code, error_code_meaning(reply.error_code))
        return reply

    # ------------------------------------------------------------------ NMT and SDO

    async def nmt(self, command: NmtCommand) -> None:
        """Send an NMT command to this drive (there is no reply)."""
        self._send(NMT_COB_ID, encode_nmt(command, self.cob.node))

    async def sdo_download(self, index: int, subindex: int, value: int, size: int = 4) -> None:
        """Write an object with an expedited SDO download.

        Raises:
            SdoAbortError: The drive aborted the transfer.
            DriveTimeout: No reply in time.
        """
        frame = await self._sdo(encode_sdo_download(index, subindex, value, size),
                                f"SDO write 0x{index:04X}:{subindex}")
        if frame.kind is not SdoKind.DOWNLOAD_ACK:
            raise BusError(f"unexpected SDO reply {frame.kind.value} to a download")

    async def sdo_upload(self, index: int, subindex: int) -> int:
        """Read an object with an expedited SDO upload; returns its unsigned value.

        Raises:
            SdoAbortError: The drive aborted the transfer.
            DriveTimeout: No reply in time.
        """
        frame = await self._sdo(encode_sdo_upload_request(index, subindex), f"SDO read 0x{index:04X}:{subindex}")
        if frame.kind is not SdoKind.UPLOAD_REPLY or frame.value is None:
            raise BusError(f"unexpected SDO reply {frame.kind.value} to an upload")
        return frame.value

    async def _sdo(self, payload: bytes, what: str) -> SdoFrame:
        # One SDO channel per node: transfers are strictly sequential.
        async with self._sdo_lock:
            future: asyncio.Future[SdoFrame] = self._new_future()
            self._sdo_pending = future
            try:
                self._send(self.cob.sdo_request, payload)
                frame = await self._wait(future, what)
            finally:
                self._sdo_pending = None
        if frame.kind is SdoKind.ABORT:
            code = frame.abort_code or 0
            raise SdoAbortError(frame.index, frame.subindex, code, SDO_ABORT_CODES.get(code, "unknown abort code"))
        return frame

    # ------------------------------------------------------------------ plumbing

    def _new_future(self) -> asyncio.Future[Any]:
        if self._closed:
            raise BusError("the driver is closed")
        if self._notifier is None:
            raise BusError("the driver is not started (use 'async with' or call start())")
        return asyncio.get_running_loop().create_future()

    async def _wait(self, future: asyncio.Future[Any], what: str) -> Any:
        try:
            with self._clock.holding() if self._clock is not None else contextlib.nullcontext():
                async with asyncio.timeout(self.timeout):
                    return await future
        except TimeoutError:
            raise DriveTimeout(
                f"drive {self.cob.node} did not answer {what} within {self.timeout * 1000:.0f} ms"
            ) from None

    def _send(self, arbitration_id: int, payload: bytes) -> None:
        if self._closed:
            raise BusError("the driver is closed")
        message = can.Message(arbitration_id=arbitration_id, data=payload, is_extended_id=False)
        try:
            self.bus.send(message, timeout=self.timeout)
        except can.CanError as exc:
            raise BusError(f"CAN bus refused frame 0x{arbitration_id:03X}: {exc}") from exc

    def _on_message(self, message: can.Message) -> None:
        """Dispatch one received frame (runs on the event loop)."""
        if self._closed or message.is_extended_id or message.is_error_frame or message.is_remote_frame:
            return
        arbitration_id, data = message.arbitration_id, bytes(message.data)
        try:
            if arbitration_id == self.cob.interpreter_reply:
                reply = InterpreterReply.decode(data)
                future = self._pending.get((reply.mnemonic, reply.index))
                if future is None or future.done():
                    self.unmatched_frames += 1
                else:
                    future.set_result(reply)
            elif arbitration_id == self.cob.sdo_reply:
                frame = decode_sdo(data, from_server=True)
                if self._sdo_pending is None or self._sdo_pending.done():
                    self.unmatched_frames += 1
                else:
                    self._sdo_pending.set_result(frame)
            elif arbitration_id == self.cob.emcy:
                self._on_emergency(decode_emcy(data))
            elif arbitration_id == self.cob.heartbeat and len(data) >= 1:
                self.nmt_state = NmtState(data[0] & 0x7F) if data[0] & 0x7F in NmtState._value2member_map_ else None
        except CodecError:
            # A malformed frame matches no request; the request it was meant for times out.
            self.unmatched_frames += 1

    def _on_emergency(self, emergency: Emergency) -> None:
        self.emergencies.append(emergency)
        self.latched_emergency = None if emergency.is_reset else emergency
        _log.warning("drive %d: %s", self.cob.node, emergency.description)
        for listener in list(self._listeners):
            listener(emergency)


def _name(mnemonic: str, index: int) -> str:
    return f"{mnemonic}[{index}]" if index else mnemonic
