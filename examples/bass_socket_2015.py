"""Stream binaural audio from ``bass`` through the 2015 dedicated socket, as the Two!Ears MATLAB client did.

Start a gateway first (the simulated binaural scene is the default sound card)::

    aiogenomix-gateway                          # or --audio-device hw:1,0 on the rig
    python examples/bass_socket_2015.py --seconds 3

The script loads ``bass``, opens its dedicated socket and starts ``Acquire``,
then asks the socket for up to 100 ms of frames at a time from frame 1 on, the first
captured frame (``Read Port - N 4410 - nfr <i>``), printing each block's frame indices, the
frames lost and the level of each ear; at the end it closes the socket and
stops the acquisition.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from aiogenomix.clients import AudioSocketError, FrameSocketClient, GenomixError, connect


def level_db(samples: np.ndarray) -> float:
    """RMS level of int32 samples in dB below full scale."""
    rms = float(np.sqrt(np.mean(np.square(samples.astype(np.float64))))) if samples.size else 0.0
    return 20 * np.log10(max(rms, 1.0) / 2**31)


def main() -> int:
    """Acquire, stream, print; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--address", default="localhost:8080", help="the gateway (default localhost:8080)")
    parser.add_argument("--socket-port", type=int, default=8081,
                        help="the gateway's --audio-socket-port (default 8081)")
    parser.add_argument("--seconds", type=float, default=3.0, help="seconds of audio to read (default 3)")
    parser.add_argument("--token", default=None, help="the gateway's --token, if it has one")
    args = parser.parse_args()

    rate, block = 44100, 4410
    try:
        with connect(args.address, token=args.token) as gateway:
            bass = gateway.load("bass")
            socket = bass.DedicatedSocket(ack=True)       # serves until CloseSocket
            acquire = bass.Acquire(device="sim", sampleRate=rate, nFramesPerChunk=2205, nChunksOnPort=20,
                                   ack=True)
            got, lost = 0, 0
            # From frame 1, the first captured one: frame 0 and below are the zeros of a window still filling.
            audio = FrameSocketClient("127.0.0.1", args.socket_port, max_frames=block, next_frame=1,
                                      token=args.token)
            connect_until = time.monotonic() + 10
            while True:                                   # the socket opens as DedicatedSocket starts
                try:
                    audio.connect()
                    break
                except AudioSocketError:
                    if time.monotonic() > connect_until:
                        raise
                    time.sleep(0.05)
            with audio:
                while got < args.seconds * rate:
                    frames = audio.read()
                    if frames.count == 0:
                        time.sleep(block / rate / 4)      # nothing new yet: the next chunk is on its way
                        continue
                    got, lost = got + frames.count, lost + frames.lost
                    print(f"frames {frames.first_frame:8d}…{frames.next_frame - 1:8d}  lost {frames.lost:6d}  "
                          f"left {level_db(frames.left):6.1f} dB  right {level_db(frames.right):6.1f} dB",
                          flush=True)
            bass.CloseSocket()
            bass.Stop()
            socket.wait(10)
            acquire.wait(10)
            ended = acquire.exception.ex if acquire.exception is not None else acquire.status  # type: ignore[attr-defined]
            print(f"read {got} frames ({got / rate:.2f} s), {lost} lost; socket {socket.status}, "
                  f"acquisition ended ({ended})")
    except (GenomixError, AudioSocketError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
