"""Sweep the simulated KEMAR head through a simulated sound scene and plot what its ears hear.

Runs the merged ``kemarcapture`` component in-process (simulated drive on a
virtual CAN bus, simulated binaural scene), homes the head, starts the capture
and the dedicated socket, sweeps the head left and right, and streams the audio
with the head azimuth of every chunk through the dedicated-socket client.  The
scene is one noise source at +30° (a scene file of its own, written next to
the plot), heard through the measured KEMAR HRIRs; the plot (a PNG; no display
needed) shows the left and right samples, the head azimuth, and the interaural
delay measured on the captured frames next to that of the measured responses
(GCC-PHAT) and the Woodworth formula of a sphere::

    python examples/capture_sweep.py --amplitude 60 --out capture_sweep.png

By default the simulation runs ten times faster than real time.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: write a file, never open a window

import matplotlib.pyplot as plt
import numpy as np

from aiogenomix.clients.audio_socket import AsyncAudioSocketClient, AudioBlock
from aiogenomix.components.audio import woodworth_itd
from aiogenomix.components.binaural import HorizontalInterpolator, gcc_phat_itd, load_kemar
from aiogenomix.components.core import ComponentHost, HostSettings, ScaledClock
from aiogenomix.components.kemarcapture import KemarCapture

RATE, CHUNK_MS = 44100, 50
FRAMES_PER_CHUNK = RATE * CHUNK_MS // 1000
MAX_LAG = 40  # samples: more than the largest interaural delay of the head
SOURCE_AZIMUTH = 30.0
#: One broadband source, so the cross-correlation shows its delay alone.
SCENE = {"seed": 1, "noise_floor": -70, "sources": [{"type": "noise", "azimuth": SOURCE_AZIMUTH, "level": -24}]}


def kemar_itd_ms(relative: np.ndarray) -> np.ndarray:
    """The ITD (ms, right ear behind the left) of the measured KEMAR responses at *relative* azimuths (degrees)."""
    responses = HorizontalInterpolator(load_kemar().resampled(RATE)).at(relative)
    return np.array([1000.0 * gcc_phat_itd(*r.T, max_lag=MAX_LAG) / RATE for r in responses])


def interaural_delay_ms(frames: np.ndarray) -> float:
    """Delay of the right ear behind the left (ms) at the cross-correlation peak of one chunk."""
    left, right = frames[:, 0].astype(np.float64), frames[:, 1].astype(np.float64)
    core = slice(MAX_LAG, len(left) - MAX_LAG)
    lags = np.arange(-MAX_LAG, MAX_LAG + 1)
    correlation = [np.dot(left[core], right[MAX_LAG + lag:len(right) - MAX_LAG + lag]) for lag in lags]
    return 1000.0 * lags[int(np.argmax(correlation))] / RATE


async def record_sweep(device: str, amplitude: float, speed: float, sweeps: int,
                       time_scale: float) -> list[AudioBlock]:
    """Run the rig, sweep the head, and return every block the socket client received."""
    settings = HostSettings(can="virtual", audio_device=device, audio_socket_port=0)
    async with ComponentHost(clock=ScaledClock(time_scale), settings=settings,
                             factories={"kemarcapture": KemarCapture}) as host:
        rig = await host.load("kemarcapture")
        homing = await rig.send("Homing")
        await homing.ended.wait()
        socket = await rig.send("DedicatedSocket")
        capture = await rig.send("StartCapture", {"device": device, "transfer_rate": RATE,
                                                  "chunk_time": CHUNK_MS, "Port_chunks": 40})
        port = await rig.wait_socket()
        blocks: list[AudioBlock] = []
        sweeping = True

        async def stream() -> None:
            async with AsyncAudioSocketClient(port=port, frames_per_chunk=FRAMES_PER_CHUNK,
                                              positions=True) as audio:
                async for block in audio.stream(interval=0.2 * CHUNK_MS / 1000 / time_scale):
                    blocks.append(block)
                    if not sweeping:
                        return

        reader = asyncio.create_task(stream())
        for target in [amplitude, -amplitude] * sweeps + [0.0]:
            move = await rig.send("MoveAbsolutePosition", {"target": target, "velocity": speed})
            await move.ended.wait()
            if move.status != "done":
                raise RuntimeError(f"MoveAbsolutePosition({target}) failed: {move.exception}")
        sweeping = False
        await reader
        for request in (capture, socket):
            await rig.interrupt(request, by="example")
    return blocks


def plot(blocks: list[AudioBlock], out: str) -> None:
    """Plot the samples, the head azimuth and the interaural delay per chunk into *out*."""
    frames = np.concatenate([b.frames for b in blocks])
    positions = np.concatenate([b.positions for b in blocks if b.positions is not None])
    lost = sum(b.lost for b in blocks)
    chunks = frames.reshape(-1, FRAMES_PER_CHUNK, 2)
    t_chunk = (np.arange(len(chunks)) + 1) * CHUNK_MS / 1000          # end of each chunk
    t_frame = np.arange(len(frames)) / RATE
    # A chunk is heard while the head moves from the previous chunk's end to its own: compare at its middle.
    middles = (np.concatenate([positions[:1], positions[:-1]]) + positions) / 2
    sphere = [1000 * woodworth_itd(SOURCE_AZIMUTH - az) for az in middles]
    predicted = kemar_itd_ms(SOURCE_AZIMUTH - middles)
    measured = [interaural_delay_ms(chunk) for chunk in chunks]

    fig, (ax_audio, ax_head, ax_itd) = plt.subplots(3, 1, sharex=True, figsize=(10, 8))
    scale = 2.0 ** 31
    ax_audio.plot(t_frame, frames[:, 0] / scale, lw=0.3, label="left")
    ax_audio.plot(t_frame, frames[:, 1] / scale, lw=0.3, alpha=0.7, label="right")
    ax_audio.set_ylabel("sample (full scale)")
    ax_audio.legend(loc="upper right")
    ax_audio.set_title(f"Simulated KEMAR sweep: {len(chunks)} chunks, {lost} lost")
    ax_head.plot(t_chunk, positions, drawstyle="steps-pre")
    ax_head.axhline(SOURCE_AZIMUTH, ls="--", c="gray", label=f"noise source at {SOURCE_AZIMUTH:+.0f}°")
    ax_head.set_ylabel("head azimuth (deg)")
    ax_head.legend(loc="upper right")
    ax_itd.plot(t_chunk, measured, ".", ms=3, label="measured (cross-correlation)")
    ax_itd.plot(t_chunk, predicted, lw=1, label="measured KEMAR HRIRs (GCC-PHAT)")
    ax_itd.plot(t_chunk, sphere, lw=1, ls="--", label="Woodworth (a sphere)")
    ax_itd.set_ylabel("right-ear delay (ms)")
    ax_itd.set_xlabel("capture time (s)")
    ax_itd.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def main() -> int:
    """Record a sweep and plot it; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--amplitude", type=float, default=60.0, help="sweep between -A and +A degrees (default 60)")
    parser.add_argument("--speed", type=float, default=60.0, help="head speed in deg/s (default 60)")
    parser.add_argument("--sweeps", type=int, default=1, help="left-right sweeps (default 1)")
    parser.add_argument("--time-scale", type=float, default=10.0, help="simulation speed-up (default 10)")
    parser.add_argument("--out", default="capture_sweep.png", help="the PNG to write (default capture_sweep.png)")
    args = parser.parse_args()
    scene = Path(args.out).with_suffix(".scene.json")
    scene.write_text(json.dumps(SCENE, indent=2))
    blocks = asyncio.run(record_sweep(f"sim:{scene}", args.amplitude, args.speed, args.sweeps, args.time_scale))
    plot(blocks, args.out)
    print(f"wrote {args.out}: {sum(b.count for b in blocks)} chunks, {sum(b.lost for b in blocks)} lost")
    return 0


if __name__ == "__main__":
    sys.exit(main())
