"""The room renderer against Eyring and an independent simulator: the figures of docs/localisation.md.

A 6 × 4 × 3 m shoebox at three absorptions, a source at (1.5, 1.2, 1.4) m and four listening places.
For each: Eyring's RT60; the T20 (Schroeder backward integration, octave bands 500 Hz-4 kHz, the decays
of all responses averaged) of our binaural room responses through the MIT KEMAR, of pyroomacoustics'
image sources to order 3 with ray tracing (scattering 0.3, seeded), and of its image sources alone to
order 40; the direct-to-reverberant ratio at omnidirectional points, ours and the hybrid's, averaged over
the places. Needs the dev extra (pyroomacoustics)::

    .venv/bin/python examples/room_acoustics.py
"""

from __future__ import annotations

import numpy as np
import pyroomacoustics as pra
from scipy import signal

from aiogenomix.components.binaural import HrirSet, Pose, Shoebox, load_kemar, room_response

RATE = 16_000.0
DIMENSIONS = (6.0, 4.0, 3.0)
SOURCE = (1.5, 1.2, 1.4)
PLACES = np.array([(4.2, 2.7, 1.6), (4.5, 1.2, 1.2), (2.5, 3.0, 1.8), (5.0, 2.0, 1.4)])
BANDS = (500.0, 1000.0, 2000.0, 4000.0)


def t20(responses: list[np.ndarray], centre: float) -> float:
    """T20 of an octave band: the responses' Schroeder integrals averaged, fitted from -5 to -25 dB."""
    sos = signal.butter(4, [centre / np.sqrt(2), centre * np.sqrt(2)], "bandpass", fs=RATE, output="sos")
    length = min(len(r) for r in responses)
    decay = np.zeros(length)
    for response in responses:
        energy = np.cumsum(signal.sosfiltfilt(sos, response[:length])[::-1] ** 2)[::-1]
        decay += energy / energy[0]
    level = 10 * np.log10(decay / decay[0])
    first, last = int(np.argmax(level <= -5.0)), int(np.argmax(level <= -25.0))
    return float(-60.0 / np.polyfit(np.arange(first, last) / RATE, level[first:last], 1)[0])


def drr(response: np.ndarray, arrival: float) -> float:
    """Direct-to-reverberant ratio, dB: within 2.5 ms of the arrival against all after."""
    half, at = int(0.0025 * RATE), int(round(arrival))
    direct = np.sum(response[max(0, at - half):at + half] ** 2)
    return float(10 * np.log10(direct / np.sum(response[at + half:] ** 2)))


def probe() -> HrirSet:
    """Two point microphones at the head's centre: a unit sample in every direction."""
    azimuth = np.tile(np.arange(-180.0, 180.0, 10.0), 7)
    taps = np.zeros((len(azimuth), 64, 2))
    taps[:, 0, :] = 1.0
    return HrirSet(RATE, azimuth, np.repeat(np.arange(-90.0, 91.0, 30.0), 36), taps, "two points")


def simulated(alpha: float, hybrid: bool) -> list[np.ndarray]:
    """The simulator's responses at the four places: image sources and ray tracing, or image sources alone."""
    pra.random.seed(1)
    room = pra.ShoeBox(list(DIMENSIONS), fs=int(RATE), materials=pra.Material(alpha, 0.3 if hybrid else None),
                       max_order=3 if hybrid else 40, air_absorption=False, ray_tracing=hybrid)
    if hybrid:
        room.set_ray_tracing(receiver_radius=0.5, n_rays=10_000, energy_thres=1e-7)
    room.add_source(list(SOURCE))
    room.add_microphone_array(PLACES.T)
    room.compute_rir()
    return [np.asarray(room.rir[m][0]) for m in range(len(PLACES))]


def main() -> None:
    """Print the table."""
    kemar = load_kemar()
    arrivals = np.linalg.norm(PLACES - np.asarray(SOURCE), axis=1) / 343.0 * RATE
    print("| α | Eyring | ours (KEMAR) | pyroomacoustics, hybrid | pyroomacoustics, image sources only "
          "| DRR ours | DRR hybrid |")
    print("|---:|---:|---|---|---|---:|---:|")
    for alpha in (0.15, 0.25, 0.4):
        room = Shoebox.with_absorption(DIMENSIONS, alpha)
        seconds = 1.2 * float(room.eyring_rt60()[2]) + 0.1
        ours = [room_response(SOURCE, Pose(*p, facing=170.0), rate=RATE, seconds=seconds, room=room, hrirs=kemar,
                              seed=i) for i, p in enumerate(PLACES)]
        omni = [room_response(SOURCE, Pose(*p), rate=RATE, seconds=seconds, room=room, hrirs=probe(), seed=i)[:, 0]
                for i, p in enumerate(PLACES)]
        hybrid, specular = simulated(alpha, True), simulated(alpha, False)
        peaks = [int(np.argmax(np.abs(r[:int(a + 0.01 * RATE)]))) for r, a in zip(hybrid, arrivals, strict=True)]

        def times(responses: list[np.ndarray]) -> str:
            return ", ".join(f"{t20(responses, c):.3f}" for c in BANDS)

        mine_drr = np.mean([drr(r, a) for r, a in zip(omni, arrivals, strict=True)])
        their_drr = np.mean([drr(r, p) for r, p in zip(hybrid, peaks, strict=True)])
        print(f"| {alpha} | {room.eyring_rt60()[2]:.3f} | {times([r[:, e] for r in ours for e in (0, 1)])} | "
              f"{times(hybrid)} | {times(specular)} | {mine_drr:.1f} dB | {their_drr:.1f} dB |")


if __name__ == "__main__":
    main()
