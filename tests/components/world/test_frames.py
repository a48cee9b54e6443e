"""The frame pool: frames published in place and read-only, slots reused only when no reader holds them."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from aiogenomix.components.world._frames import FramePool


def _draw(pool: FramePool, slot: int, value: int) -> None:
    """What the render process does: write a frame into a slot (here through a second mapping)."""
    import mmap

    with mmap.mmap(pool.fileno(), 0) as memory:
        memory[slot * pool.frame_bytes:(slot + 1) * pool.frame_bytes] = bytes([value]) * pool.frame_bytes


def test_a_published_frame_is_the_shared_memory_read_only_and_its_slot_waits_for_its_last_view() -> None:
    pool = FramePool(frame_bytes=16, slots=2, spares=1)
    slot = pool.take(0)
    _draw(pool, slot, 7)
    frame = pool.publish(slot)
    assert frame.tolist() == [7] * 16 and not frame.flags.owndata  # no copy
    with pytest.raises(ValueError):
        frame[0] = 1
    with pytest.raises(ValueError):
        frame.flags.writeable = True
    view = frame.reshape(4, 4)
    del frame
    gc.collect()
    assert pool.free == 1  # the view still holds the slot
    del view
    assert pool.free == 2
    pool.close()


def test_frames_held_beyond_the_slots_are_drawn_in_a_spare_and_published_as_copies() -> None:
    pool = FramePool(frame_bytes=8, slots=2, spares=1)
    held = []
    for value in range(4):
        slot = pool.take(0)
        _draw(pool, slot, value)
        held.append(pool.publish(slot))
    # The first two in place, the next two copies of the spare: every frame kept what it showed.
    assert [int(frame[0]) for frame in held] == [0, 1, 2, 3]
    assert pool.copies == 2 and pool.free == 0
    assert not held[3].flags.writeable and held[3].flags.owndata
    held.clear()
    assert pool.free == 2
    pool.close()


def test_a_frame_outlives_its_pool() -> None:
    pool = FramePool(frame_bytes=4, slots=1, spares=1)
    slot = pool.take(0)
    _draw(pool, slot, 9)
    frame = pool.publish(slot)
    pool.close()
    del pool
    gc.collect()
    assert np.array_equal(frame, [9, 9, 9, 9])
