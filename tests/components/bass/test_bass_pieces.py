"""bass's Audio port read from its immutable chunks: the same bytes as a direct encoding, by frame, never torn."""

from __future__ import annotations

import aiohttp
import numpy as np
import orjson

from aiogenomix.components.bass import Bass
from aiogenomix.components.bass._history import AudioSnapshot, ChunkHistory
from aiogenomix.components.core.runtime import idl_type
from aiogenomix.components.core.runtime import encode_binary

FPC = 50
NUMPY = orjson.OPT_SERIALIZE_NUMPY


def joined(pieces: list[bytes | memoryview]) -> bytes:
    return b"".join(bytes(piece) for piece in pieces)


def history(chunks: int, capacity: int = 6) -> ChunkHistory:
    rng = np.random.default_rng(3)
    held = ChunkHistory(capacity, FPC, 44100)
    for _ in range(chunks):
        held.append(rng.integers(-2**31, 2**31, FPC), rng.integers(-2**31, 2**31, FPC))
    return held


def expected(snapshot: AudioSnapshot, since: int | None, binary: bool) -> bytes:
    port_type = idl_type(Bass.Audio.annotation)
    if since is None:
        data, extra = snapshot.data, {}
    else:
        data, lost = snapshot.since(since)
        extra = {"lost": lost}
    if binary:
        return joined(encode_binary("Audio", port_type.encode(data), **extra))
    return orjson.dumps({"Audio": port_type.encode(data), **extra}, option=NUMPY)


async def test_reads_by_frame_are_the_direct_encoding_of_the_snapshot(bass: Bass, url: str) -> None:
    fresh = ChunkHistory(6, FPC, 44100).snapshot  # zero-filled, frame 0
    for snapshot in (AudioSnapshot.empty(), fresh, history(3).snapshot, history(11).snapshot):
        bass.Audio.publish(snapshot)
        last = snapshot.last_frame_index
        async with aiohttp.ClientSession() as http:
            for since in (None, 0, 1, FPC - 1, FPC, FPC + 7, last - FPC, last - 1, last, last + 9):
                if since is not None and since < 0:
                    continue
                for binary in (False, True):
                    params = {"format": "binary" if binary else "json"}
                    if since is not None:
                        params["since"] = str(since)
                    async with http.get(f"{url}/module/bass/read/Audio", params=params) as reply:
                        assert await reply.read() == expected(snapshot, since, binary), (since, binary)


def test_a_snapshot_keeps_its_chunks_as_chunks() -> None:
    snapshot = history(8).snapshot
    data, lost = snapshot.chunked(snapshot.last_frame_index - FPC - 3)
    assert lost == 0 and data.left.size == FPC + 3 and len(data.left.chunks) == 2
    np.testing.assert_array_equal(data.left.numpy(), snapshot.since(snapshot.last_frame_index - FPC - 3)[0].left)
    whole, _ = snapshot.chunked()
    # Views of the published chunks, not copies.
    assert all(np.shares_memory(c.array, chunk) for c, chunk in zip(whole.left.chunks, snapshot.chunks, strict=True))
