"""The ``bass`` component: the 2015 binaural audio stream server of Two!Ears (``bass.gen``)."""

from __future__ import annotations

import asyncio
import logging
from typing import Annotated, Any

from ..audio import (
    MAX_FRAMES_PER_CHUNK, RATE_RANGE, AudioError, Azimuth, CaptureBackend, FormatRefused, SocketPorts,
    list_capture_devices, open_for_host, prepare_for_host,
)
from ..core import (
    Component, ComponentHost, Out, OutPort, OverBudget, Reservation, String, Task, ThrottledLog, ULong, activity,
    function, Unit,
)
from ._history import AudioSnapshot, ChunkHistory
from ._socket_server import FrameSocketServer
from ._types import AudioPortData, DeviceList, e_device, e_hwparams, e_nodevice, e_nomem, e_socket, e_swparams

__all__ = ["Bass"]

log = logging.getLogger(__name__)
#: Lines a client's requests cause (each Acquire, ListDevices, DedicatedSocket, overruns): rate-limited.
_client_log = ThrottledLog(log)


def _port_what(chunks: int, frames: int) -> str:
    return f"a port of {chunks} chunks of {frames} frames"


class Bass(Component, name="bass", version="1.0"):
    """Binaural audio stream server (Two!Ears, 2015): streams a stereo sound device on a frame-indexed port.

    ``Acquire`` captures chunks of ``nFramesPerChunk`` frames and publishes the
    newest ``nChunksOnPort`` chunks on ``Audio`` (``binaudio::portStruct``),
    with ``lastFrameIndex`` the index of the newest frame.  ``DedicatedSocket``
    serves the same frames over TCP: ``Read Port - N <n> - nfr <i>`` gets at most
    *n* frames from frame *i* on (the 2015 MATLAB client's protocol).  Devices:
    ``sim`` (simulated binaural scene, following the simulated KEMAR head when
    one is loaded), ``sim:<scene.json>``, ``file:<path.wav>``, ``mcap:<recording.mcap>``, ``pa:<name>``
    (PortAudio) or any ALSA name (``hw:1,0``).
    """

    capture = Task(doc="Reads chunks from the sound device and publishes them on Audio")
    socket = Task(doc="Serves the dedicated TCP socket")
    # Published as snapshots of the chunk history (read piece by piece); encoded as AudioPortData.
    Audio = OutPort(AudioPortData, view=AudioSnapshot,
                    doc="The newest nChunksOnPort chunks of binaural audio, indexed by frame")

    def __init__(self, host: ComponentHost, instance: str, argv: list[str] | None = None) -> None:
        super().__init__(host, instance, argv)
        #: Where the simulated scene reads the head azimuth (None: the HeadAzimuth a
        #: component of the host provides, else 0°).  Set it to steer the scene from a script.
        self.head_azimuth: Azimuth | None = None
        self._server: FrameSocketServer | None = None
        self._socket_open = asyncio.Event()
        self._close_socket = asyncio.Event()
        #: The port's bytes, held against the host's audio_bytes while its chunks are published.
        self._port_memory: Reservation | None = None

    async def on_start(self) -> None:
        """Publish an empty port: readers may connect before the first acquisition."""
        await super().on_start()
        self.Audio.publish(AudioSnapshot.empty())
        await prepare_for_host(self.host, self.clock, 44100)   # a sim acquisition at the default rate starts at once

    async def on_stop(self) -> None:
        if self._server is not None:
            await self._server.aclose()
        if self._port_memory is not None:
            self._port_memory.release()
        await super().on_stop()

    @classmethod
    def service_defaults(cls, host: ComponentHost) -> dict[str, dict[str, Any]]:
        """Acquire's default device comes from the host (``--audio-device``; ``sim`` by default)."""
        defaults = super().service_defaults(host)
        defaults.setdefault("Acquire", {})["device"] = host.settings.audio_device
        return defaults

    # -- reading the state from Python ------------------------------------------------------

    @property
    def snapshot(self) -> AudioSnapshot:
        """The newest publication of ``Audio``."""
        snapshot = self.Audio.read()
        return snapshot

    @property
    def socket_port(self) -> int:
        """The TCP port the dedicated socket listens on (0 while closed)."""
        return self._server.port if self._server is not None else 0

    async def wait_socket(self) -> int:
        """Wait until the dedicated socket listens; return its port."""
        await self._socket_open.wait()
        return self.socket_port

    # -- services ---------------------------------------------------------------------------

    @function(throws=(e_nodevice,))
    async def ListDevices(self) -> Annotated[DeviceList, Out("devices", "Device strings that Acquire accepts")]:
        """Print available devices for sound capture on standard output.

        Here they are also the service's output and go to the gateway's log.
        """
        devices = await asyncio.to_thread(list_capture_devices)
        if not devices:
            raise e_nodevice(what="no capture device found")
        _client_log.info("%s: capture devices: %s", self.instance, ", ".join(devices))
        return devices

    def _validate_acquire(self, device: str, sampleRate: int, nFramesPerChunk: int, nChunksOnPort: int) -> None:
        if nFramesPerChunk < 1 or nChunksOnPort < 1:
            raise e_nomem(what=f"a port holds 1 chunk of 1 frame or more, not {nChunksOnPort} chunks of "
                               f"{nFramesPerChunk} frames")
        try:
            self.host.settings.budgets.check("port_bytes", _port_what(nChunksOnPort, nFramesPerChunk),
                                             8 * nFramesPerChunk * nChunksOnPort)
        except OverBudget as exc:
            raise e_nomem(what=str(exc)) from None
        if not RATE_RANGE[0] <= sampleRate <= RATE_RANGE[1]:
            raise e_hwparams(device=device, what=f"sampleRate {sampleRate} Hz is outside "
                                                 f"{RATE_RANGE[0]}…{RATE_RANGE[1]} Hz")
        if nFramesPerChunk > MAX_FRAMES_PER_CHUNK:
            raise e_hwparams(device=device, what=f"nFramesPerChunk {nFramesPerChunk} is more than the "
                                                 f"{MAX_FRAMES_PER_CHUNK} frames of the largest period")

    async def _open(self, device: str, rate: int, frames: int) -> CaptureBackend:
        try:
            backend = open_for_host(self.host, device, rate, frames, self.clock, azimuth=self.head_azimuth)
            await backend.open()
        except FormatRefused as exc:
            raise e_hwparams(device=device, what=str(exc)) from exc
        except AudioError as exc:  # no such device, library missing, device busy, bad scene/WAV file
            raise e_device(device=device, what=str(exc)) from exc
        return backend

    @activity(task=capture, interrupts=("Acquire",), validate=_validate_acquire,
              throws=(e_nomem, e_device, e_hwparams, e_swparams), progress="Audio.lastFrameIndex")
    async def Acquire(
        self,
        device: Annotated[String, "ALSA name of the sound device"] = "hw:1,0",
        sampleRate: Annotated[ULong, Unit("Hz"), "Sample rate in Hz"] = 44100,
        nFramesPerChunk: Annotated[ULong, "Chunk size in frames"] = 2205,
        nChunksOnPort: Annotated[ULong, "Port size in chunks"] = 20,
    ) -> None:
        """Acquire data from an audio device and stream it on a port.

        The port restarts zero-filled at frame 0.  A new Acquire interrupts the
        running one; Stop ends it.  A file source ends the request when the file does.
        """
        # While the device opens, the port held is the larger of the last acquisition's (still published)
        # and this one's; once this one's port replaces it, this one's alone.
        if self._port_memory is None:
            self._port_memory = self.host.ledgers.audio.reserve(0, self.instance, "a port")
        memory, held = self._port_memory, 8 * nFramesPerChunk * nChunksOnPort
        before = memory.amount
        try:
            memory.resize(max(before, held), _port_what(nChunksOnPort, nFramesPerChunk))
        except OverBudget as exc:
            raise e_nomem(what=str(exc)) from None
        history = ChunkHistory(nChunksOnPort, nFramesPerChunk, sampleRate)
        try:
            backend = await self._open(device, sampleRate, nFramesPerChunk)
        except BaseException:
            memory.resize(before, "")  # the last acquisition's port stays
            raise
        self.Audio.publish(history.snapshot)
        memory.resize(held, "")
        _client_log.info("%s: acquiring %s at %d Hz, %d frames per chunk, %d chunks on Audio",
                         self.instance, device, sampleRate, nFramesPerChunk, nChunksOnPort)
        try:
            while (chunk := await backend.read()) is not None:
                snapshot = history.append(chunk.left, chunk.right)
                if chunk.overrun:
                    _client_log.warning("%s: %s lost %d frames before frame %d", self.instance, device,
                                        chunk.lost_frames, snapshot.last_frame_index - nFramesPerChunk + 1)
                self.Audio.publish(snapshot)
        except AudioError as exc:
            raise e_device(device=device, what=str(exc)) from exc
        finally:
            await backend.aclose()

    @function(interrupts=("Acquire",))
    def Stop(self) -> None:
        """Stop acquisition of audio data."""

    def _validate_socket(self) -> None:
        if self._server is not None or any(r.service.name == "DedicatedSocket" for r in self.requests.running()):
            raise e_socket(port=self.socket_port, what=f"the dedicated socket is already open on port "
                                                       f"{self.socket_port}")

    @activity(task=socket, validate=_validate_socket, throws=(e_socket,))
    async def DedicatedSocket(self) -> None:
        """Serve the Audio port over TCP (``Read Port - N <n> - nfr <i>``) until CloseSocket.

        The port is the gateway's ``--audio-socket-port`` (8081 by default).
        CloseSocket ends this request normally (done), as in bass.
        """
        settings = self.host.settings
        server = FrameSocketServer(lambda: self.snapshot, host=settings.audio_socket_host,
                                   port=settings.audio_socket_port, token=settings.audio_socket_token,
                                   budgets=settings.budgets, ledger=self.host.ledgers.sockets)
        ports = self.host.shared(SocketPorts, SocketPorts)
        try:
            await server.start()
        except OSError as exc:
            raise e_socket(port=server.requested_port, what=ports.why_refused(server.requested_port, exc)) from exc
        self._server = server
        self._close_socket.clear()
        self._socket_open.set()
        _client_log.info("%s: dedicated socket (2015 protocol) open on port %d", self.instance, server.port)
        try:
            with ports.held(server.port, self.instance):
                await self._close_socket.wait()
        finally:
            self._server = None
            self._socket_open.clear()
            await server.aclose()

    @activity(task=socket)
    async def CloseSocket(self) -> None:
        """Close the dedicated socket and disconnect its clients (nothing to do when it is closed)."""
        serving = [r for r in self.requests.running() if r.service.name == "DedicatedSocket"]
        self._close_socket.set()
        for request in serving:
            if request.task is not None:
                await asyncio.shield(asyncio.wait({request.task}))
