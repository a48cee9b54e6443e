"""The ``capture`` component: the binaural audio stream server (seed chapter 5, appendix 9.5.1)."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Annotated, Any, ClassVar

from ..audio import (
    MAX_FRAMES_PER_CHUNK, RATE_RANGE, AudioError, Azimuth, CaptureBackend, Chunk, ChunkWindow,
    DedicatedSocketServer, DeviceNotFound, SocketPorts, list_capture_devices, open_for_host, prepare_for_host,
)
from ..core import (
    Component, ComponentHost, OutPort, OverBudget, Reservation, String, Task, ThrottledLog, ULong, activity, attribute,
    function, Unit,
)
from ._types import (
    ALREADY_CAPTURING, DEVICE_ERROR, ERROR_SEQUENCE_ENOMEM, INVALID_CHUNK_TIME, NO_SUCH_DEVICE, SOCKET_ERROR,
    CaptureConfig, CaptureStatus, PortData,
)
from ._port_view import PortView

__all__ = ["Capture", "HeadPositionSource", "frames_per_chunk"]

#: Where the head azimuth published with each chunk comes from: awaited as each chunk
#: arrives, it gives the azimuth in degrees (positive = left; NaN when unknown).
HeadPositionSource = Callable[[], Awaitable[float]]

log = logging.getLogger(__name__)
#: Lines a client's requests cause (each StartCapture, each DedicatedSocket): rate-limited.
_client_log = ThrottledLog(log)


def _every_source(backend_devices: list[str]) -> list[str]:
    """Every device string a capture accepts here: the listed devices, then the sources named by path.

    Lists the sound libraries' devices, which may block: call it off the event loop.
    """
    listed = [*backend_devices, *(d for d in list_capture_devices() if d not in backend_devices)]
    return [*listed, "file:<path.wav>", "sim:<scene.json>", "mcap:<recording.mcap>"]


def _port_what(chunks: int, frames: int) -> str:
    return f"a port of {chunks} chunks of {frames} frames"


def frames_per_chunk(transfer_rate: int, chunk_time: int) -> int:
    """Frames in a chunk of *chunk_time* ms at *transfer_rate* Hz.

    Raises:
        INVALID_CHUNK_TIME: when that is not a whole number of frames, or out of range.
    """
    if not RATE_RANGE[0] <= transfer_rate <= RATE_RANGE[1]:
        raise INVALID_CHUNK_TIME(what=f"transfer_rate {transfer_rate} Hz is outside "
                                      f"{RATE_RANGE[0]}…{RATE_RANGE[1]} Hz")
    frames, remainder = divmod(transfer_rate * chunk_time, 1000)
    if remainder:
        raise INVALID_CHUNK_TIME(what=f"{chunk_time} ms at {transfer_rate} Hz is {transfer_rate * chunk_time / 1000} "
                                      "frames, not a whole number")
    if not 1 <= frames <= MAX_FRAMES_PER_CHUNK:
        raise INVALID_CHUNK_TIME(what=f"{chunk_time} ms at {transfer_rate} Hz is {frames} frames per chunk, "
                                      f"outside 1…{MAX_FRAMES_PER_CHUNK}")
    return frames


class Capture(Component, name="capture", version="1.1"):
    """Binaural audio stream server: captures a stereo sound device and streams the newest chunks.

    The ``Port`` out port holds the last ``Port_chunks`` chunks (non-interleaved
    int32 left and right samples, oldest first) with the index of the newest
    chunk and the capture start time.  ``DedicatedSocket`` also serves them in
    binary over TCP: ``Read Port - Index <k>`` gets the chunks after *k*.
    Devices: ``sim`` (simulated binaural scene), ``sim:<scene.json>``,
    ``file:<path.wav>``, ``mcap:<recording.mcap>`` (a recording played again), ``pa:<name>`` (PortAudio)
    or any ALSA name (``hw:1,0``).
    """

    retrieve_data = Task(doc="Reads chunks from the sound device and publishes them on Port")
    socket = Task(doc="Serves the dedicated TCP socket")
    # Published as views of the chunk window (incremental reads); encoded as PortData.
    Port = OutPort(PortData, view=PortView, doc="The last Port_chunks chunks of binaural audio, oldest first")

    #: The struct published on Port.
    port_data: ClassVar[type[PortData]] = PortData

    def __init__(self, host: ComponentHost, instance: str, argv: list[str] | None = None) -> None:
        super().__init__(host, instance, argv)
        #: Where the simulated scene reads the head azimuth (None: the HeadAzimuth a
        #: component of the host provides, such as kemar's simulated drive, else 0°).
        #: Set it to steer the simulated head from a script or a test.
        self.head_azimuth: Azimuth | None = None
        self._config = CaptureConfig(device="", transfer_rate=44100, chunk_time=50, Port_chunks=20)
        self._window: ChunkWindow | None = None
        self._backend: CaptureBackend | None = None
        self._server: DedicatedSocketServer | None = None
        self._socket_open = asyncio.Event()
        #: The port's bytes, held against the host's audio_bytes while the window exists.
        self._port_memory: Reservation | None = None

    async def on_start(self) -> None:
        """Publish an empty Port: incremental readers may start before the first capture."""
        await super().on_start()
        self.Port.publish(PortView(None, make=self.port_data))
        await prepare_for_host(self.host, self.clock, self._config.transfer_rate)   # sim starts at once

    @classmethod
    def service_defaults(cls, host: ComponentHost) -> dict[str, dict[str, Any]]:
        """StartCapture's default device comes from the host (``--audio-device``; ``sim`` by default)."""
        defaults = super().service_defaults(host)
        defaults.setdefault("StartCapture", {})["device"] = host.settings.audio_device
        return defaults

    async def on_stop(self) -> None:
        # Activities are interrupted before on_stop, so the socket task has closed
        # the server; closing again covers a server opened outside an activity.
        if self._server is not None:
            await self._server.aclose()
        if self._port_memory is not None:
            self._port_memory.release()
        await super().on_stop()

    # -- reading the state from Python ------------------------------------------------------

    @property
    def window(self) -> ChunkWindow | None:
        """The chunk window of the current (or last) capture."""
        return self._window

    @property
    def socket_port(self) -> int:
        """The TCP port the dedicated socket listens on (0 while closed)."""
        return self._server.port if self._server is not None else 0

    async def wait_socket(self) -> int:
        """Wait until the dedicated socket listens (DedicatedSocket binds it as it starts); return its port."""
        await self._socket_open.wait()
        return self.socket_port

    @property
    def capturing(self) -> bool:
        """Whether a capture is running."""
        return self._backend is not None

    # -- capture -----------------------------------------------------------------------------

    def _validate_start(self, device: str, transfer_rate: int, chunk_time: int, Port_chunks: int) -> None:
        frames = frames_per_chunk(transfer_rate, chunk_time)
        if Port_chunks < 1:
            raise ERROR_SEQUENCE_ENOMEM(what="a port holds 1 chunk or more, not 0")
        try:
            self.host.settings.budgets.check("port_bytes", _port_what(Port_chunks, frames), 8 * frames * Port_chunks)
        except OverBudget as exc:
            raise ERROR_SEQUENCE_ENOMEM(what=str(exc)) from None
        # Checked by request rather than by state: a StartCapture just sent has not
        # run yet, but its request exists.
        running = [r for r in self.requests.running() if r.service.name == "StartCapture"]
        if running:
            raise ALREADY_CAPTURING(device=running[0].inputs["device"])

    def _port_reservation(self) -> Reservation:
        """The port's bytes held against the host's audio_bytes (nothing before the first capture)."""
        if self._port_memory is None:
            self._port_memory = self.host.ledgers.audio.reserve(0, self.instance, "a port")
        return self._port_memory

    def head_position_source(self) -> HeadPositionSource | None:
        """Where the head position published with each chunk comes from (None: the chunks carry none).

        A component that moves a head (``kemarcapture``) returns its source here
        and publishes a :attr:`port_data` with a ``positions`` member; the
        dedicated socket then appends the positions to each reply.
        """
        return None

    @property
    def port_positions(self) -> bool:
        """Whether the port and the dedicated socket carry a head position per chunk."""
        return self.head_position_source() is not None

    async def _open(self, device: str, rate: int, frames: int) -> CaptureBackend:
        try:
            backend = open_for_host(self.host, device, rate, frames, self.clock, azimuth=self.head_azimuth)
            await backend.open()
        except DeviceNotFound as exc:
            # The backend knows only its own devices: the user needs every source this gateway opens.
            available = await asyncio.to_thread(_every_source, exc.available)
            raise NO_SUCH_DEVICE(device=device, available=available) from exc
        except AudioError as exc:  # library missing, device refusing the format, bad scene/WAV file
            raise DEVICE_ERROR(device=device, what=str(exc)) from exc
        return backend

    @activity(task=retrieve_data, throws=(INVALID_CHUNK_TIME, ERROR_SEQUENCE_ENOMEM, NO_SUCH_DEVICE, DEVICE_ERROR,
                                          ALREADY_CAPTURING), validate=_validate_start, progress="Port.index")
    async def StartCapture(
        self,
        device: Annotated[String, "Name of the sound device"] = "hw:1,0",
        transfer_rate: Annotated[ULong, Unit("Hz"), "Sample rate in Hz"] = 44100,
        chunk_time: Annotated[ULong, Unit("ms"), "Size of transfer chunks in milliseconds"] = 50,
        Port_chunks: Annotated[ULong, "Size of the Port in number of chunks"] = 20,
    ) -> None:
        """Capture from a sound device and publish the newest chunks on Port, until StopCapture.

        A second StartCapture while one runs ends in ALREADY_CAPTURING and leaves the running one alone.
        """
        frames = frames_per_chunk(transfer_rate, chunk_time)
        # While the device opens, the port held is the larger of the last capture's (still published)
        # and this one's; once this one's window replaces it, this one's alone.
        memory, held = self._port_reservation(), 8 * frames * Port_chunks
        before = memory.amount
        try:
            memory.resize(max(before, held), _port_what(Port_chunks, frames))
        except OverBudget as exc:
            raise ERROR_SEQUENCE_ENOMEM(what=str(exc)) from None
        try:
            backend = await self._open(device, transfer_rate, frames)
        except BaseException:
            memory.resize(before, "")  # the last capture's port stays
            raise
        head_position = self.head_position_source()
        window = ChunkWindow(Port_chunks, frames, with_positions=head_position is not None)
        self._config = CaptureConfig(device, transfer_rate, chunk_time, Port_chunks)
        memory.resize(held, "")
        self._window, self._backend = window, backend
        _client_log.info("%s: capturing %s at %d Hz, %d frames per chunk, %d chunks on Port",
                         self.instance, device, transfer_rate, frames, Port_chunks)
        try:
            if head_position is not None:
                await self._pump_with_positions(backend, window, head_position)
            else:
                while (chunk := await backend.read()) is not None:
                    self._publish_chunk(window, chunk, None)
        except AudioError as exc:
            raise DEVICE_ERROR(device=device, what=str(exc)) from exc
        finally:
            self._backend = None
            await backend.aclose()

    async def _pump_with_positions(self, backend: CaptureBackend, window: ChunkWindow,
                                   head_position: HeadPositionSource) -> None:
        """Publish chunks in order, each with the head position read as it arrived.

        The position is a bus round trip; waiting for it before reading the next
        chunk would delay the capture (and a simulated scene would be rendered
        late).  So a reader starts a position query as each chunk arrives and
        hands both over, and this loop publishes them in order.  At most one
        query is in flight: a chunk that arrives during one shares its answer,
        so a slow or silent bus delays publication but never piles up queries.
        A chunk whose source knows the head's azimuth (a recording played again,
        ``mcap:PATH``) is published with that one, the head not asked.
        """
        handed: asyncio.Queue[tuple[Chunk, asyncio.Future[float]] | None] = asyncio.Queue()
        queries: list[asyncio.Future[float]] = []
        loop = asyncio.get_running_loop()

        async def read() -> None:
            try:
                while (chunk := await backend.read()) is not None:
                    if chunk.head_azimuth is not None:
                        # The source knows where the head was (a recording played again): not the live head.
                        known = loop.create_future()
                        known.set_result(chunk.head_azimuth)
                        handed.put_nowait((chunk, known))
                        continue
                    if not queries or queries[-1].done():
                        queries[:] = [asyncio.ensure_future(head_position())]
                    handed.put_nowait((chunk, queries[-1]))
            finally:
                handed.put_nowait(None)

        reader = asyncio.create_task(read(), name=f"{self.instance} chunk reader")
        try:
            while (item := await handed.get()) is not None:
                chunk, position = item
                self._publish_chunk(window, chunk, await position)
            await reader  # the end of the stream, or the device's error
        finally:
            # Stopped or failed: nothing started here outlives the capture.
            started: list[asyncio.Future[Any]] = [reader, *queries]
            for task in started:
                task.cancel()
            await asyncio.gather(reader, *queries, return_exceptions=True)

    def _publish_chunk(self, window: ChunkWindow, chunk: Chunk, position: float | None) -> None:
        index = window.append(chunk.left, chunk.right, position)
        if chunk.overrun:
            _client_log.warning("%s: %s lost %d frames before chunk %d", self.instance, self._config.device,
                                chunk.lost_frames, index)
        # The capture start, re-anchored on the newest chunk: after an overrun the
        # frames of later chunks keep computable times (ts + frame / rate).
        start = chunk.time - (index - 1) * window.frames_per_chunk / self._config.transfer_rate
        self.Port.publish(self._port_value(window, start))

    def _port_value(self, window: ChunkWindow, start: float) -> PortView:
        return PortView(window, self._config.transfer_rate, start, self.port_data)

    @function(interrupts=("StartCapture",))
    def StopCapture(self) -> None:
        """Stop the capture (StartCapture ends, interrupted); the Port keeps its last chunks."""

    @attribute
    def GetCaptureConfig(self) -> CaptureConfig:
        """The parameters of the current (or last) capture."""
        return self._config

    @function
    def GetCaptureStatus(self) -> CaptureStatus:
        """Whether the capture runs, its index and overruns, and the dedicated socket's port and clients."""
        backend, window, server = self._backend, self._window, self._server
        return CaptureStatus(
            capturing=backend is not None, device=self._config.device,
            index=window.last_index if window is not None else 0,
            overruns=backend.overruns if backend is not None else 0,
            lost_frames=backend.lost_frames if backend is not None else 0,
            socket_port=server.port if server is not None else 0,
            socket_clients=server.clients if server is not None else 0,
        )

    # -- the dedicated socket ----------------------------------------------------------------

    def _validate_socket(self) -> None:
        if self._server is not None or any(r.service.name == "DedicatedSocket" for r in self.requests.running()):
            raise SOCKET_ERROR(port=self.socket_port, what=f"the dedicated socket is already open "
                                                           f"on port {self.socket_port}")

    @activity(task=socket, throws=(SOCKET_ERROR,), validate=_validate_socket)
    async def DedicatedSocket(self) -> None:
        """Serve Port's chunks over TCP (``Read Port - Index <k>``) until CloseSocket.

        The port is the gateway's ``--audio-socket-port`` (8081 by default); read it with GetCaptureStatus.
        """
        settings = self.host.settings
        server = DedicatedSocketServer(lambda: self._window, host=settings.audio_socket_host,
                                       port=settings.audio_socket_port, with_positions=self.port_positions,
                                       token=settings.audio_socket_token, budgets=settings.budgets,
                                       ledger=self.host.ledgers.sockets)
        ports = self.host.shared(SocketPorts, SocketPorts)
        try:
            await server.start()
        except OSError as exc:
            raise SOCKET_ERROR(port=server.requested_port, what=ports.why_refused(server.requested_port, exc)) from exc
        self._server = server
        self._socket_open.set()
        _client_log.info("%s: dedicated socket open on port %d", self.instance, server.port)
        try:
            with ports.held(server.port, self.instance):
                # Serve until interrupted (CloseSocket, abort or kill): the server's own
                # tasks answer the clients.
                await asyncio.get_running_loop().create_future()
        finally:
            self._server = None
            self._socket_open.clear()
            await server.aclose()

    @activity(task=socket, interrupts=("DedicatedSocket",))
    async def CloseSocket(self) -> None:
        """Close the dedicated socket and disconnect its clients (nothing to do when it is closed)."""
