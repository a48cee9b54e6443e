"""The ``basc`` component (``basc.gen``): reads consecutive blocks of frames from ``bass`` through an in port."""

from __future__ import annotations

import dataclasses
import logging
from typing import Annotated

import numpy as np

from ..bass import AudioPortData, AudioSnapshot, Samples
from ..core import (
    Component, GenomException, InPort, Long, Out, OutPort, OverBudget, Reservation, String, Task, ThrottledLog, ULong,
    ULongLong, activity, function, idl_struct,
)

__all__ = ["Basc", "BlockReport", "e_noData", "e_nomem"]

log = logging.getLogger(__name__)
#: A reader falling behind loses frames at every period: its lines are rate-limited.
_client_log = ThrottledLog(log)


def _no_samples() -> np.ndarray:
    return np.zeros(0, dtype=np.int32)


@idl_struct("basc::BlockReport")
class BlockReport:
    """What GetBlocks has read: the last complete block and the losses so far.

    An aiogenomix addition to basc.gen, whose codels only print this, so that it
    can be seen over HTTP.
    """

    blocks: ULong = 0
    firstFrameIndex: ULongLong = 0
    nFrames: ULong = 0
    lost: ULongLong = 0
    left: Samples = dataclasses.field(default_factory=_no_samples)
    right: Samples = dataclasses.field(default_factory=_no_samples)


#: Bytes a frame of a block takes (left and right int32).
_BLOCK_BYTES_PER_FRAME = 8


class e_noData(GenomException):
    """The server is not streaming or the Audio port is not connected."""

    what: String


class e_nomem(GenomException):
    """The block asked for is larger than the gateway allows (``--max-block-frames``, ``--max-audio-bytes``)."""

    what: String


class Basc(Component, name="basc", version="1.0"):
    """Binaural audio stream client (Two!Ears, 2015): gets consecutive blocks of frames from bass.

    Connect ``Audio`` to ``bass/Audio`` with ``connect_port``, then ``GetBlocks``.
    Each completed block is published on ``Blocks`` with its first frame index
    and the frames lost so far.
    """

    read = Task(period=0.25, doc="Reads the Audio port, every 250 ms")
    Audio = InPort(AudioPortData, doc="Connect to bass/Audio with connect_port")
    Blocks = OutPort(BlockReport, doc="The last complete block of GetBlocks, its first frame, "
                                      "and the frames lost so far")

    #: The memory of the blocks, held against the host's audio_bytes (None before the first GetBlocks).
    _blocks_memory: Reservation | None = None

    async def on_start(self) -> None:
        await super().on_start()
        self.Blocks.publish(BlockReport())

    def _audio(self) -> AudioSnapshot:
        # bass in this process publishes its snapshot object (a view of the port struct); bass in
        # another process arrives as the struct itself, from which the snapshot is rebuilt.
        published: object = self.Audio.read()
        if isinstance(published, AudioPortData):
            published = AudioSnapshot.from_data(published)
        if not isinstance(published, AudioSnapshot) or not published.chunks:
            raise e_noData(what="the Audio port is not connected to bass/Audio" if published is None
                           else "bass is not acquiring (send Acquire first)")
        return published

    def _validate_blocks(self, nBlocks: int, nFramesPerBlock: int, startOffs: int) -> None:
        try:
            self.host.settings.budgets.check("block_frames", f"a block of {nFramesPerBlock} frames", nFramesPerBlock)
        except OverBudget as exc:
            raise e_nomem(what=str(exc)) from None

    def _block_reservation(self) -> Reservation:
        """The memory of the blocks (the one published, the one being filled) held against the host's audio_bytes."""
        if self._blocks_memory is None:
            self._blocks_memory = self.host.ledgers.audio.reserve(0, self.instance, "blocks")
        return self._blocks_memory

    async def on_stop(self) -> None:
        if self._blocks_memory is not None:
            self._blocks_memory.release()
        await super().on_stop()

    @activity(task=read, interrupts=("GetBlocks",), throws=(e_noData, e_nomem), validate=_validate_blocks,
              progress="Blocks.blocks")
    async def GetBlocks(
        self,
        nBlocks: Annotated[ULong, "Amount of blocks, 0 for unlimited"] = 1,
        nFramesPerBlock: Annotated[ULong, "Blocks size in frames"] = 12000,
        startOffs: Annotated[Long, "Starting offset (past < 0, future > 0)"] = -12000,
    ) -> Annotated[ULong, Out("nBlocks", "Amount of blocks, 0 for unlimited")]:
        """Get consecutive blocks of audio data from bass.

        The first block starts ``startOffs`` frames from the newest frame on the
        port.  Each period, the frames available are added to the current block;
        frames that bass no longer holds when they are asked for are counted as
        lost.  Ends when ``nBlocks`` blocks are complete (``nBlocks`` is then 0),
        never with 0.  A block is at most the gateway's ``--max-block-frames``
        (``e_nomem`` beyond), and its memory counts in ``--max-audio-bytes``.
        """
        snapshot = self._audio()
        if nFramesPerBlock < 1:
            return nBlocks
        self.Blocks.publish(BlockReport())  # the last block goes: this one's take its place
        memory = self._block_reservation()
        try:
            # The block being filled, and the last one completed (published).
            memory.resize(2 * _BLOCK_BYTES_PER_FRAME * nFramesPerBlock, f"blocks of {nFramesPerBlock} frames")
        except OverBudget as exc:
            memory.resize(0, "")
            raise e_nomem(what=str(exc)) from None
        try:
            return await self._collect(nBlocks, nFramesPerBlock, max(0, snapshot.last_frame_index + 1 + startOffs))
        finally:
            memory.resize(_BLOCK_BYTES_PER_FRAME * nFramesPerBlock if self.Blocks.read().blocks else 0, "")

    async def _collect(self, nBlocks: int, nFramesPerBlock: int, next_frame: int) -> int:
        """Fill blocks from *next_frame* on, publishing each as it completes; the blocks left (0: all got)."""
        block = np.empty((2, nFramesPerBlock), np.int32)  # filled in place: one copy of the frames
        filled, block_start, lost, done = 0, next_frame, 0, 0
        while True:
            read = self._audio().frames(next_frame, nFramesPerBlock - filled)
            if read.lost:
                lost += read.lost
                _client_log.warning("%s: lost %d frames before frame %d", self.instance, read.lost, read.first)
            if read.count:
                if not filled:
                    block_start = read.first
                block[0, filled:filled + read.count] = read.left
                block[1, filled:filled + read.count] = read.right
                filled += read.count
            next_frame = read.next
            if filled == nFramesPerBlock:
                done += 1
                self.Blocks.publish(BlockReport(done, block_start, nFramesPerBlock, lost, block[0], block[1]))
                block, filled = np.empty((2, nFramesPerBlock), np.int32), 0
                if nBlocks:
                    nBlocks -= 1
                    if nBlocks == 0:
                        return 0
            await self.read.tick()

    @function(interrupts=("GetBlocks",))
    def Stop(self) -> None:
        """Stop getting blocks."""
