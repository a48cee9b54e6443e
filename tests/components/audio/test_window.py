"""The chunk window: absolute indices, incremental reads with losses, the zero-filled port snapshot."""

from __future__ import annotations

import numpy as np
import pytest

from aiogenomix.components.audio import ChunkWindow

FPC = 4


def chunk(index: int) -> tuple[np.ndarray, np.ndarray]:
    """A recognisable chunk: left samples are index*100 + n, right ones their negation."""
    left = index * 100 + np.arange(FPC, dtype=np.int32)
    return left, -left


def filled(count: int, capacity: int = 5, **kwargs: bool) -> ChunkWindow:
    window = ChunkWindow(capacity, FPC, **kwargs)
    for i in range(1, count + 1):
        if window.with_positions:
            window.append(*chunk(i), position=float(i))
        else:
            window.append(*chunk(i))
    return window


def test_indices_count_from_one() -> None:
    window = ChunkWindow(5, FPC)
    assert (window.last_index, window.first_index) == (0, 1)
    assert window.append(*chunk(1)) == 1
    assert window.append(*chunk(2)) == 2


@pytest.mark.parametrize("count", [0, 3, 5, 7, 12])
def test_since_returns_exactly_the_newer_chunks_oldest_first(count: int) -> None:
    window = filled(count)
    for k in range(0, count + 2):
        read = window.since(k)
        expected = list(range(max(k + 1, count - 4, 1), count + 1))
        assert read.count == len(expected)
        assert read.last_index == count
        assert read.first_index == (expected[0] if expected else count + 1)
        assert read.lost == max(0, count - k - 5) if k <= count else read.lost == 0
        for row, index in enumerate(expected):
            np.testing.assert_array_equal(read.left[row], chunk(index)[0])
            np.testing.assert_array_equal(read.right[row], chunk(index)[1])


def test_reader_from_a_later_capture_gets_nothing_and_no_loss() -> None:
    read = filled(3).since(10)
    assert (read.count, read.lost, read.last_index) == (0, 0, 3)


def test_limit_counts_the_older_chunks_as_lost() -> None:
    read = filled(12).since(6, limit=2)
    assert (read.count, read.first_index, read.lost) == (2, 11, 4)


def test_copies_survive_later_appends() -> None:
    window = filled(5)
    copy = window.since(4)
    for i in range(6, 12):
        window.append(*chunk(i))
    np.testing.assert_array_equal(copy.left[0], chunk(5)[0])


def test_snapshot_is_zero_filled_until_the_window_fills() -> None:
    snap = filled(2).snapshot()
    assert snap.left.shape == (5, FPC)
    assert snap.first_index == -2
    np.testing.assert_array_equal(snap.left[:3], 0)
    np.testing.assert_array_equal(snap.left[3:], [chunk(1)[0], chunk(2)[0]])


def test_snapshot_after_wrapping_is_contiguous_in_index_order() -> None:
    snap = filled(13).snapshot()
    np.testing.assert_array_equal(snap.left, [chunk(i)[0] for i in range(9, 14)])
    np.testing.assert_array_equal(snap.frames()[:FPC, 1], chunk(9)[1])


def test_positions_follow_their_chunks() -> None:
    window = filled(8, with_positions=True)
    read = window.since(5)
    np.testing.assert_array_equal(read.positions, [6.0, 7.0, 8.0])
    assert window.snapshot().positions.tolist() == [4.0, 5.0, 6.0, 7.0, 8.0]


def test_bad_chunks_are_refused() -> None:
    window = ChunkWindow(3, FPC)
    with pytest.raises(ValueError, match="frames per channel"):
        window.append(np.zeros(FPC + 1), np.zeros(FPC + 1))
    with pytest.raises(ValueError, match="no positions"):
        window.append(*chunk(1), position=3.0)
    with pytest.raises(ValueError, match="keeps a position"):
        ChunkWindow(3, FPC, with_positions=True).append(*chunk(1))
    with pytest.raises(ValueError):
        ChunkWindow(0, FPC)


def test_a_published_port_view_keeps_the_chunks_of_its_publication() -> None:
    """Issue 14, defect 1: a port value read late must hold the data of the publication it names."""
    from aiogenomix.components.capture import PortView

    window = filled(5)
    published = PortView(window, 16000, 0.0)
    for i in range(6, 30):                     # the window turns over several times before anyone reads
        window.append(*chunk(i))
    assert published.index == 5
    data = published.data
    assert data.index == 5
    np.testing.assert_array_equal(data.left, filled(5).snapshot().left.reshape(-1))
    newer, lost = published.since(3)
    assert newer.index == 5 and lost == 0
    np.testing.assert_array_equal(newer.left, np.concatenate([chunk(4)[0], chunk(5)[0]]))


def test_a_port_view_hands_out_its_chunks_without_copying_them() -> None:
    from aiogenomix.components.capture import PortView

    window = ChunkWindow(4, 3)
    for i in range(6):
        window.append(np.full(3, i), np.full(3, -i))
    view = PortView(window, 44100, 0.0)
    window.append(np.full(3, 9), np.full(3, 9))  # later chunks change nothing the view holds
    for since in (None, 0, 2, 3, 5, 6, 8):
        data, lost = view.chunked(since)
        expected, expected_lost = (view.data, 0) if since is None else view.since(since)
        np.testing.assert_array_equal(data.left.numpy(), expected.left)
        np.testing.assert_array_equal(data.right.numpy(), expected.right)
        assert (data.index, data.nbframes, lost) == (expected.index, expected.nbframes, expected_lost)
    whole, _ = view.chunked()
    assert all(not chunk.array.flags.writeable for chunk in whole.left.chunks)
