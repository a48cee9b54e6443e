"""The capture backends: selection by device string, ALSA on the null PCM, PortAudio, WAV, the sim, hand-over."""

from __future__ import annotations

import asyncio
import subprocess
import sys
import threading
import wave
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aiogenomix.components.audio import (
    AudioError, DeviceNotFound, SceneError, UnknownDevicePrefix, scene_renderer, DEFAULT_SCENE, known_prefixes,
    open_backend, split_device,
)
from aiogenomix.components.audio._alsa import AlsaBackend, alsa_capture_devices
from aiogenomix.components.audio._handoff import ThreadHandoff
from aiogenomix.components.audio._portaudio import portaudio_capture_devices
from aiogenomix.components.audio._sim_backend import SimulatedSceneBackend
from aiogenomix.components.core import ManualClock, ScaledClock

FPC = 2205


@pytest.mark.parametrize(("device", "expected"), [
    ("hw:1,0", ("alsa", "hw:1,0")), ("default", ("alsa", "default")), ("null", ("alsa", "null")),
    ("alsa:plughw:0", ("alsa", "plughw:0")), ("sim", ("sim", "")), ("sim:/a/b.json", ("sim", "/a/b.json")),
    ("file:x.wav", ("file", "x.wav")), ("pa", ("portaudio", "")), ("portaudio:USB", ("portaudio", "USB")),
])
def test_device_strings_pick_the_backend(device: str, expected: tuple[str, str]) -> None:
    assert split_device(device) == expected


@pytest.mark.parametrize("device", ["plughw:CARD=USB,DEV=0", "sysdefault:CARD=PCH", "front:CARD=PCH,DEV=0",
                                    "dsnoop:1", "pulse"])
def test_alsas_own_names_stay_alsas(device: str) -> None:
    assert split_device(device) == ("alsa", device)


@pytest.mark.parametrize("device", ["fiel:take.wav", "smi:scene.json", "pa2:3", "tcp:robot:7447"])
def test_an_unknown_prefix_is_refused_naming_the_known_ones(device: str) -> None:
    with pytest.raises(UnknownDevicePrefix) as refused:
        split_device(device)
    prefix = device.split(":")[0]
    assert refused.value.prefix == prefix and refused.value.known == known_prefixes()
    assert str(refused.value).startswith(f"no capture backend has the device prefix {prefix!r} (in {device!r}): "
                                         "the prefixes are alsa, file, mcap, pa, portaudio, sim")
    assert isinstance(refused.value, AudioError)   # what the components turn into their declared exceptions


def test_a_backend_and_its_library_are_imported_when_a_capture_first_uses_it() -> None:
    # A fresh interpreter: this one has imported every backend already.
    code = (
        "import sys\n"
        "from aiogenomix.components.audio import BACKENDS, backend_class, open_backend\n"
        "from aiogenomix.components.core import ManualClock\n"
        "backend = open_backend('sim', 44100, 2205, ManualClock())\n"
        "loaded = {kind for kind, where in BACKENDS.items()\n"
        "          if 'aiogenomix.components.audio' + where.split(':')[0] in sys.modules}\n"
        "print(type(backend).__name__, sorted(loaded), 'sounddevice' in sys.modules, 'alsaaudio' in sys.modules)\n"
        "print(backend_class('alsa').__name__, 'alsaaudio' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[0] == "SimulatedSceneBackend ['sim'] False False"
    assert out[1] == "AlsaBackend False"  # the class is there; the library is loaded when a device opens


async def test_simulated_scene_is_paced_by_the_clock() -> None:
    clock = ManualClock()
    backend = open_backend("sim", 44100, FPC, clock)
    async with backend:
        read = asyncio.ensure_future(backend.read())
        await clock.advance(0.049)
        assert not read.done()                  # the first chunk ends at 50 ms
        await clock.advance(0.001)
        chunk = await read
    assert chunk.frames.shape == (FPC, 2) and chunk.frames.dtype == np.int32
    reference = scene_renderer(DEFAULT_SCENE, 44100).render(FPC, 0.0)
    np.testing.assert_array_equal(chunk.frames, reference)
    assert chunk.time == pytest.approx(clock.wall() - 0.05)
    assert not chunk.overrun


async def test_the_first_simulated_chunk_renders_while_the_event_loop_goes_on() -> None:
    """The event loop runs other work while the first chunk renders (a room's makes its reflections: 100 ms)."""
    clock = ManualClock()
    loop = asyncio.get_running_loop()
    async with open_backend("sim", 44100, FPC, clock) as backend:
        assert isinstance(backend, SimulatedSceneBackend) and backend.renderer is not None
        renderer = backend.renderer
        render = renderer.render
        turned = threading.Event()

        def render_once_the_loop_has_turned(*args: Any) -> Any:
            # Rendered on the loop's own thread, the callback could not run before this returns.
            loop.call_soon_threadsafe(turned.set)
            assert turned.wait(10), "the event loop stood still while the chunk rendered"
            return render(*args)

        renderer.render = render_once_the_loop_has_turned  # type: ignore[method-assign, assignment]
        read = asyncio.ensure_future(backend.read())
        await clock.advance(0.05)
        assert read.done()  # simulated time waited for the chunk, as when the loop rendered it
        first = read.result()
        renderer.render = render  # type: ignore[method-assign]
        read = asyncio.ensure_future(backend.read())
        await clock.advance(0.05)
        second = await read
    assert first is not None and second is not None and turned.is_set()
    reference = scene_renderer(DEFAULT_SCENE, 44100)
    for chunk in (first, second):  # the same samples wherever they were rendered
        np.testing.assert_array_equal(chunk.frames, reference.render(FPC, 0.0))


async def test_simulated_chunks_carry_consecutive_times() -> None:
    clock = ScaledClock(1000)
    async with open_backend("sim", 44100, FPC, clock) as backend:
        times = [(await backend.read()).time for _ in range(5)]  # type: ignore[union-attr]
    assert np.allclose(np.diff(times), 0.05)


async def test_alsa_backend_real_code_path_on_the_null_pcm() -> None:
    # The null PCM is not paced and returns junk: this checks the plumbing only
    # (open, S32_LE stereo configuration, threaded reads, hand-over, loss accounting, close).
    backend = AlsaBackend("null", 44100, FPC, ScaledClock(1), pcm_name="null", depth=2)
    async with backend:
        chunks = [await backend.read() for _ in range(30)]
        thread = backend._thread
    assert thread is not None and not thread.is_alive()
    assert all(c is not None and c.frames.shape == (FPC, 2) and c.frames.dtype == np.int32 for c in chunks)
    times = [c.time for c in chunks if c is not None]
    assert times == sorted(times)
    for c in chunks:
        assert c is not None and c.overrun == (c.lost_frames > 0) and c.lost_frames % FPC == 0
    assert backend.lost_frames == sum(c.lost_frames for c in chunks if c is not None)


async def test_alsa_reports_a_missing_device_and_what_exists() -> None:
    with pytest.raises(DeviceNotFound) as caught:
        await open_backend("hw:9,0", 44100, FPC, ScaledClock(1)).open()
    assert caught.value.device == "hw:9,0"
    assert caught.value.available == alsa_capture_devices()
    assert "no such ALSA capture device 'hw:9,0'" in str(caught.value)


@pytest.mark.skipif(bool(portaudio_capture_devices()), reason="this machine has PortAudio input devices")
@pytest.mark.parametrize("device", ["pa", "pa:Babyface", "pa:3"])
async def test_portaudio_reports_no_such_device(device: str) -> None:
    with pytest.raises(DeviceNotFound, match=rf"no such PortAudio capture device '{device}' \(available: none\)"):
        await open_backend(device, 44100, FPC, ScaledClock(1)).open()


def write_wav(path: Path, samples: np.ndarray, width: int, channels: int, rate: int = 44100) -> None:
    with wave.open(str(path), "wb") as out:
        out.setnchannels(channels)
        out.setsampwidth(width)
        out.setframerate(rate)
        out.writeframes(samples.tobytes())


@pytest.mark.parametrize(("width", "dtype", "shift"), [(2, "<i2", 16), (4, "<i4", 0)])
async def test_wav_file_is_played_left_justified_and_ends(tmp_path: Path, width: int, dtype: str, shift: int) -> None:
    stereo = np.stack([np.arange(5000), -np.arange(5000)], axis=1).astype(dtype)
    write_wav(tmp_path / "a.wav", stereo, width, 2)
    async with open_backend(f"file:{tmp_path / 'a.wav'}", 44100, FPC, ScaledClock(1000)) as backend:
        chunks = [c async for c in backend]
    assert len(chunks) == 3                                     # 5000 frames: two full chunks and a padded one
    frames = np.concatenate([c.frames for c in chunks])
    np.testing.assert_array_equal(frames[:5000], stereo.astype(np.int64) << shift)
    np.testing.assert_array_equal(frames[5000:], 0)


async def test_wav_24_bit_mono_feeds_both_ears(tmp_path: Path) -> None:
    values = np.array([1, -1, 0x123456, -0x400000], dtype=np.int32)
    packed = values.astype("<i4").view(np.uint8).reshape(-1, 4)[:, :3].copy()
    write_wav(tmp_path / "m.wav", packed, 3, 1)
    async with open_backend(f"file:{tmp_path / 'm.wav'}", 44100, 4, ScaledClock(1000)) as backend:
        chunk = await backend.read()
    assert chunk is not None
    np.testing.assert_array_equal(chunk.frames, np.stack([values << 8] * 2, axis=1))


async def test_wav_problems_are_explained(tmp_path: Path) -> None:
    write_wav(tmp_path / "r.wav", np.zeros(10, "<i2"), 2, 1, rate=48000)
    with pytest.raises(SceneError, match="48000 Hz"):
        await open_backend(f"file:{tmp_path / 'r.wav'}", 44100, FPC, ScaledClock(1)).open()
    with pytest.raises(SceneError, match="cannot open .*missing.wav.*No such file") as missing:
        await open_backend(f"file:{tmp_path / 'missing.wav'}", 44100, FPC, ScaledClock(1)).open()
    assert "r.wav" not in str(missing.value)     # no listing of the files next to it
    (tmp_path / "junk.wav").write_bytes(b"not a wav")
    with pytest.raises(SceneError, match="not a PCM WAV"):
        await open_backend(f"file:{tmp_path / 'junk.wav'}", 44100, FPC, ScaledClock(1)).open()


async def test_bad_scene_files_are_explained(tmp_path: Path) -> None:
    cases = {"x.json": "{", "y.json": '{"sources": [{"type": "drum"}]}', "z.json": '{"loudness": 3}'}
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(SceneError):
            await open_backend(f"sim:{tmp_path / name}", 44100, FPC, ScaledClock(1)).open()
    with pytest.raises(SceneError, match="cannot open"):
        await open_backend(f"sim:{tmp_path / 'none.json'}", 44100, FPC, ScaledClock(1)).open()


async def test_handoff_reports_dropped_chunks_with_the_next_one() -> None:
    handoff = ThreadHandoff(asyncio.get_running_loop(), depth=2)
    frames = np.zeros((10, 2), dtype=np.int32)
    results = [handoff.put(frames, float(t)) for t in range(5)]  # room for two; three dropped
    assert results == [True, True, False, False, False]
    first, second = await handoff.get(), await handoff.get()
    assert first is not None and second is not None and not first.overrun and not second.overrun
    handoff.overrun(7)                                           # a device overrun on top
    assert handoff.put(frames, 5.0)
    third = await handoff.get()
    assert third is not None and third.overrun and third.lost_frames == 3 * 10 + 7 and third.time == 5.0
    handoff.fail(RuntimeError("unplugged"))
    with pytest.raises(RuntimeError, match="unplugged"):
        await handoff.get()
    handoff.end()
    assert await handoff.get() is None
    assert await handoff.get() is None
