"""``replay`` refuses clearly what it cannot play: a recording changed or removed since it was loaded.

``Play`` reads the file again (off the event loop): when it is gone or no longer a recording, it
ends in ``::replay::NOT_PLAYING`` saying why, and leaves no file open.  Simulated time.
"""

from __future__ import annotations

import gc
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from aiogenomix.components.core import ComponentHost, HostSettings, LoadError, VirtualClock
from aiogenomix.components.recording import Recording, create_recording
from aiogenomix.components.replay import Replay

READING = {"name": "Reading", "doc": "A reading", "type": {"name": "double", "kind": "double"}}


@pytest.fixture
async def loaded(tmp_path: Path) -> AsyncIterator[tuple[ComponentHost, Path]]:
    """A replay loaded with a recording of three readings."""
    stream, path, *_ = create_recording(str(tmp_path / "readings.mcap"), None)
    recording = Recording.open(stream, path, {})
    port = recording.add_port("probe/Reading", READING)
    for k in range(3):
        port.write(float(k), rig_time=1000.0 + k)  # type: ignore[call-arg]
    await recording.close("test")
    settings = HostSettings(audio_socket_port=0, record_dirs=(str(tmp_path),), audio_files=())
    async with ComponentHost(clock=VirtualClock(), settings=settings, factories={"replay": Replay}) as host:
        await host.load("replay", ["-file", "readings.mcap"])
        yield host, Path(path)


@pytest.mark.parametrize(("change", "why"), [
    ("remove", "there is no such recording"),
    ("spoil", "is not an MCAP file (it does not begin as one)"),
])
async def test_a_recording_changed_since_the_load_ends_play_saying_why(
        loaded: tuple[ComponentHost, Path], change: str, why: str) -> None:
    host, path = loaded
    if change == "remove":
        path.unlink()
    else:
        path.write_bytes(b"not a recording any more")
    replay = host.instances["replay"]
    play = await replay.send("Play")
    await play.ended.wait()
    assert play.status == "error" and play.exception["ex"] == "::replay::NOT_PLAYING", play.exception
    assert why in play.exception["detail"]["what"]
    gc.collect()  # a file left open would say so now (ResourceWarning, an error in the suite)
    assert not replay.Status.read().playing


async def test_a_path_with_a_control_character_is_refused_at_load(loaded: tuple[ComponentHost, Path]) -> None:
    host, _ = loaded
    with pytest.raises(LoadError, match=r"holds a control character \('\\x00'\)"):
        await host.load("replay", ["-i", "other", "-file", "readings\x00.mcap"])
