"""The ``basc`` component (``basc.gen``): reads consecutive blocks of frames from ``bass`` through an in port."""

from __future__ import annotations

import dataclasses
import logging
from typing import Annotated

import numpy as np

from ..bass import AudioPortData, AudioSnapshot, Samples
from ..core import (
    Component, GenomException, InPort, Long, Out, OutPort, String, Task, ULong, ULongLong, activity, function,
    idl_struct,
)

__all__ = ["Basc", "BlockReport", "e_noData"]

log = logging.getLogger(__name__)


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


class e_noData(GenomException):
    """The server is not streaming or the Audio port is not connected."""

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

    @activity(task=read, interrupts=("GetBlocks",), throws=(e_noData,))
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
        never with 0.
        """
        snapshot = self._audio()
        if nFramesPerBlock < 1:
            return nBlocks
        next_frame = max(0, snapshot.last_frame_index + 1 + startOffs)
        pieces: list[tuple[np.ndarray, np.ndarray]] = []
        block_start, needed, lost, done = next_frame, nFramesPerBlock, 0, 0
        self.Blocks.publish(BlockReport())
        while True:
            read = self._audio().frames(next_frame, needed)
            if read.lost:
                lost += read.lost
                log.warning("%s: lost %d frames before frame %d", self.instance, read.lost, read.first)
            if read.count:
                if not pieces:
                    block_start = read.first
                pieces.append((read.left, read.right))
                needed -= read.count
            next_frame = read.next
            if needed == 0:
                done += 1
                left = np.concatenate([p[0] for p in pieces])
                right = np.concatenate([p[1] for p in pieces])
                self.Blocks.publish(BlockReport(done, block_start, nFramesPerBlock, lost, left, right))
                pieces, needed = [], nFramesPerBlock
                if nBlocks:
                    nBlocks -= 1
                    if nBlocks == 0:
                        return 0
            await self.read.tick()

    @function(interrupts=("GetBlocks",))
    def Stop(self) -> None:
        """Stop getting blocks."""
