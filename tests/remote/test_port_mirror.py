"""The gateway's mirror of a remote port answers every read exactly as the port itself (sans I/O, no Zenoh)."""

from __future__ import annotations

from typing import Any

import numpy as np
import orjson
import pytest

from aiogenomix.components.bass._history import ChunkHistory
from aiogenomix.components.bass._types import AudioPortData
from aiogenomix.components.audio import ChunkWindow
from aiogenomix.components.capture import PortData, PortView
from aiogenomix.components.core import InPort, Ledger, OverBudget
from aiogenomix.components.core.runtime import RemoteUnreachable, idl_type
from aiogenomix.components.core._ports import OutPort
from aiogenomix.components.kemarcapture._types import KemarPortData
from aiogenomix.gateway._pieces import json_pieces
from aiogenomix.remote._exporter import PortEncoder
from aiogenomix.remote._mirror import MirroredOutPort
from aiogenomix.remote._wire import decode_message


class _Port:
    """An out port holding whatever the test publishes (what PortEncoder reads)."""

    def __init__(self, annotation: Any) -> None:
        self.spec = OutPort(annotation)
        self.spec.name = "Port"
        self.name = "Port"
        self.type = idl_type(annotation)
        self.value: Any = None
        self.version = 0
        self.withdrawn = None

    def read(self, name: str | None = None) -> Any:
        return self.value


def _json(port_type: Any, value: Any) -> bytes:
    return b"".join(json_pieces(port_type.encode(value)))


def _check_every_read(port: _Port, mirror: MirroredOutPort) -> None:
    value, copy = port.value, mirror.read_kept()
    assert copy.index == value.index
    assert _json(port.type, value.chunked(None)[0]) == _json(mirror.type, copy.chunked(None)[0])
    for since in range(0, value.index + 3):
        theirs, lost = value.chunked(since)
        ours, our_lost = copy.chunked(since)
        assert (our_lost, _json(mirror.type, ours)) == (lost, _json(port.type, theirs)), since
    # The joined form (a watcher's) too.
    assert orjson.dumps(copy.since(1)[0], option=orjson.OPT_SERIALIZE_NUMPY) == \
        orjson.dumps(port.type.encode(value.since(1)[0]), option=orjson.OPT_SERIALIZE_NUMPY)


def _relay(encoder: PortEncoder, mirror: MirroredOutPort, drop: bool = False) -> None:
    for message in encoder.messages():
        if not drop:
            mirror.apply(*decode_message(message))


@pytest.mark.parametrize("positions", [False, True])
def test_a_capture_window_is_mirrored_exactly(positions: bool) -> None:
    rng = np.random.default_rng(1)
    window = ChunkWindow(5, 4, with_positions=positions)
    kind = KemarPortData if positions else PortData
    port = _Port(kind)
    port.value = PortView(window, 44100, 12.5, make=kind)
    encoder = PortEncoder(port)  # type: ignore[arg-type]
    mirror = MirroredOutPort({"name": "Port", "kind": "simple", "type": {"name": "capture::port_t"}}, None)
    _relay(encoder, mirror)  # the base: the zero window
    _check_every_read(port, mirror)
    for step in range(12):
        for _ in range(1 + step % 3):  # sometimes several chunks between two publications
            window.append(rng.integers(-9, 9, 4), rng.integers(-9, 9, 4), float(step) if positions else None)
        port.value = PortView(window, 44100, 12.5, make=kind)
        _relay(encoder, mirror)
        _check_every_read(port, mirror)


def test_a_bass_port_read_inside_a_chunk_is_mirrored_exactly() -> None:
    rng = np.random.default_rng(2)
    history = ChunkHistory(3, 4, 16000)
    port = _Port(AudioPortData)
    port.value = history.snapshot
    encoder = PortEncoder(port)  # type: ignore[arg-type]
    mirror = MirroredOutPort({"name": "Port", "kind": "simple", "type": {"name": "bass::Audio"}}, None)
    _relay(encoder, mirror)
    for _ in range(7):
        port.value = history.append(rng.integers(-9, 9, 4), rng.integers(-9, 9, 4))
        _relay(encoder, mirror)
        _check_every_read(port, mirror)


def test_a_missing_message_is_counted_as_lost_not_hidden() -> None:
    window = ChunkWindow(6, 2)
    port = _Port(PortData)
    encoder = PortEncoder(port)  # type: ignore[arg-type]
    mirror = MirroredOutPort({"name": "Port", "kind": "simple", "type": {"name": "capture::port_t"}}, None)
    for chunk in range(1, 5):
        window.append([chunk, chunk], [chunk, chunk])
        port.value = PortView(window)
        _relay(encoder, mirror, drop=chunk == 3)  # the message of chunk 3 never arrives
    assert mirror.gaps == 1
    data, lost = mirror.read_kept().chunked(1)
    assert lost == 1 and list(data["left"].numpy()) == [2, 2, 4, 4] and data["nbframes"] == 4


class _Proxy:
    """What a mirror asks of its proxy: whether its host is heard from."""

    instance = "capture"

    def __init__(self) -> None:
        self.silent = False

    def check_heard(self) -> None:
        if self.silent:
            raise RemoteUnreachable("capture runs on robot1, not heard from for 3.0 s")


def test_an_in_port_connected_to_a_silent_host_s_port_is_refused_as_its_reads_are() -> None:
    window = ChunkWindow(4, 2)
    port = _Port(PortData)
    encoder = PortEncoder(port)  # type: ignore[arg-type]
    proxy = _Proxy()
    mirror = MirroredOutPort({"name": "Port", "kind": "simple", "type": idl_type(PortData).describe()},
                             proxy)  # type: ignore[arg-type]
    window.append([1, 1], [1, 1])
    port.value = PortView(window)
    _relay(encoder, mirror)
    reader = InPort(PortData).runtime(None)
    reader.spec.name = "Audio"
    reader.connect(mirror, "capture/Port")
    assert reader.read().index == 1  # type: ignore[union-attr]
    proxy.silent = True
    with pytest.raises(RemoteUnreachable):
        reader.read()


def test_a_window_the_gateway_s_audio_budget_cannot_hold_is_refused_naming_the_flag() -> None:
    window = ChunkWindow(8, 1000)  # 8 chunks of 1000 frames: 64000 bytes
    port = _Port(PortData)
    encoder = PortEncoder(port)  # type: ignore[arg-type]
    ledger = Ledger("audio_bytes", 40_000, "--max-audio-bytes")
    mirror = MirroredOutPort({"name": "Port", "kind": "simple", "type": {"name": "capture::port_t"}},
                             _Proxy(), ledger)  # type: ignore[arg-type]
    for chunk in range(3):
        window.append(np.full(1000, chunk), np.full(1000, chunk))
        port.value = PortView(window)
        _relay(encoder, mirror)
    with pytest.raises(OverBudget, match="--max-audio-bytes"):
        mirror.read()
    assert ledger.held == 0  # nothing kept
    mirror.release()
    # With room, the next base is kept again, and held.
    roomy = Ledger("audio_bytes", 100_000, "--max-audio-bytes")
    kept = MirroredOutPort({"name": "Port", "kind": "simple", "type": {"name": "capture::port_t"}},
                           _Proxy(), roomy)  # type: ignore[arg-type]
    kept.apply(*decode_message(PortEncoder(port).base()))  # type: ignore[arg-type]
    assert kept.read().index == 3 and roomy.held == 64_000
    kept.release()
    assert roomy.held == 0
