"""The render process of ``world``: draws MuJoCo cameras into shared memory and sweeps lasers, on request.

Run by :class:`~aiogenomix.components.world._render.SensorRenderer` as a script of its own
(``python -P _render_worker.py FD PARENT``), it imports nothing of aiogenomix: only numpy and MuJoCo,
so it starts in the time MuJoCo takes to import.  Everything it needs comes in its first message.
On Linux it asks to be killed when its parent dies (``PR_SET_PDEATHSIG``): a gateway that is
killed, or stops without the time to end its worlds, leaves no render process drawing on.

Messages go both ways as a 4-octet big-endian length and a pickle (see :func:`read_message`):

* in ``("open", xml, width, height, laser)``, out ``("ready",)`` or ``("error", text)``;
* in ``("render", seq, qpos, [(camera, slot), ...], with_laser)``, out ``("frames", seq, ranges)``
  (``ranges`` None without the laser) or ``("error", seq, text)``.

Frames go into slots of the shared memory the parent passed (file descriptor ``FD``): slot *n*
holds ``height * width * 4`` octets from offset ``n * height * width * 4``, RGBA, top row first.
The process ends when its standard input closes.
"""

from __future__ import annotations

import mmap
import os
import pickle
import signal
import struct
import sys
import traceback
from typing import Any, BinaryIO

__all__ = ["read_message", "write_message", "pack_message", "unpack_message", "HEADER", "main"]

#: The frame of a message: its length in octets.
HEADER = struct.Struct(">I")
#: How much lower than the gateway the render process runs (``nice``), from its start: frames are best
#: effort (as MORSE's), the gateway's requests and audio capture come first when the CPUs are busy. The
#: start (MuJoCo, the OpenGL context, the model) too, though the cameras are down until it ends and busy
#: cores make it slow (beside three CPU hogs, the recovery test's 15 starts take 75 s, 26 s at the gateway's
#: priority): a start competing at the gateway's priority is what can make a capture lose a chunk.
NICENESS = 10


def pack_message(message: Any) -> bytes:
    """*message* framed for the pipe: its length, then its pickle."""
    body = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    return HEADER.pack(len(body)) + body


def unpack_message(body: bytes) -> Any:
    """The message whose pickle is *body* (the octets after its header)."""
    return pickle.loads(body)


def write_message(stream: BinaryIO, message: Any) -> None:
    """Write one framed *message* to *stream* and flush it."""
    stream.write(pack_message(message))
    stream.flush()


def read_message(stream: BinaryIO) -> Any:
    """The next framed message on *stream*, or None at its end."""
    head = stream.read(HEADER.size)
    if len(head) < HEADER.size:
        return None
    (length,) = HEADER.unpack(head)
    body = stream.read(length)
    if len(body) < length:
        return None
    return unpack_message(body)


class _Sensors:
    """The renderer, its own MjData, and the shared frame slots."""

    def __init__(self, memory: mmap.mmap, xml: str, width: int, height: int, laser: dict[str, Any]) -> None:
        import mujoco
        import numpy as np

        self._np, self._mujoco = np, mujoco
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self.width, self.height = width, height
        self._frame_bytes = width * height * 4
        self._memory = memory
        self._rgb = np.empty((height, width, 3), np.uint8)
        self._alpha_set: set[int] = set()
        self.renderer = mujoco.Renderer(self.model, height, width)  # the OpenGL context: fails here
        self._laser = laser
        angles = laser["angle_min"] + laser["angle_increment"] * np.arange(laser["count"])
        self._directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
        self._groups = np.ones(6, np.uint8)
        self._groups[laser["hidden_group"]] = 0

    def _slot(self, slot: int) -> Any:
        return self._np.frombuffer(self._memory, self._np.uint8, self._frame_bytes,
                                   slot * self._frame_bytes).reshape(self.height, self.width, 4)

    def render(self, qpos: Any, cameras: list[tuple[str, int]], with_laser: bool) -> Any:
        """Draw each ``(camera, slot)`` into its shared slot at the joint positions *qpos*.

        Returns the laser's ranges (float32) when *with_laser*, else None.
        """
        mujoco, model, data = self._mujoco, self.model, self.data
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_camlight(model, data)
        for camera, slot in cameras:
            self.renderer.update_scene(data, camera)
            self.renderer.render(out=self._rgb)
            frame = self._slot(slot)
            frame[..., :3] = self._rgb
            if slot not in self._alpha_set:  # opaque, and set once: MuJoCo reads RGB only
                frame[..., 3] = 255
                self._alpha_set.add(slot)
        return self._scan() if with_laser else None

    def _scan(self) -> Any:
        np, mujoco, model, data, laser = self._np, self._mujoco, self.model, self.data, self._laser
        site = data.site(laser["site"])
        origin = np.array(site.xpos)
        vec = (self._directions @ np.array(site.xmat).reshape(3, 3).T).reshape(-1)
        count = laser["count"]
        geomid = np.zeros(count, np.int32)
        dist = np.zeros(count, np.float64)
        mujoco.mj_multiRay(model, data, origin, vec, self._groups, 1, -1, geomid, dist, None, count,
                           laser["range_max"])
        ranges = np.where(geomid < 0, laser["range_max"], np.clip(dist, laser["range_min"], laser["range_max"]))
        return ranges.astype(np.float32)

    def close(self) -> None:
        """Release the OpenGL context."""
        self.renderer.close()


def _error(exc: BaseException) -> str:
    return "".join(traceback.format_exception_only(type(exc), exc)).strip()


def serve(fd: int, inbox: BinaryIO, outbox: BinaryIO) -> None:
    """Answer the parent's messages on *inbox* / *outbox* until *inbox* ends."""
    size = os.fstat(fd).st_size
    memory = mmap.mmap(fd, size)
    os.close(fd)  # the mapping keeps the memory; nothing to leak when this process ends
    sensors = None
    try:
        while (message := read_message(inbox)) is not None:
            kind = message[0]
            if kind == "open":
                try:
                    sensors = _Sensors(memory, *message[1:])
                except Exception as exc:
                    write_message(outbox, ("error", _error(exc)))
                    return
                write_message(outbox, ("ready",))
            elif kind == "render" and sensors is not None:
                _, seq, qpos, cameras, with_laser = message
                try:
                    reply = ("frames", seq, sensors.render(qpos, cameras, with_laser))
                except Exception as exc:
                    reply = ("error", seq, _error(exc))
                write_message(outbox, reply)
            else:
                write_message(outbox, ("error", f"unexpected message {kind!r}"))
    finally:
        if sensors is not None:
            sensors.close()


def _die_with_parent(parent: int) -> None:
    """Have the kernel kill this process when its parent dies (Linux); end now if it already has."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        pr_set_pdeathsig = 1
        libc.prctl(pr_set_pdeathsig, signal.SIGKILL, 0, 0, 0)
    except (OSError, AttributeError):
        return  # no prctl: the closed pipe still ends this process after its frame
    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(0)


def main(argv: list[str]) -> int:
    """The script's entry: ``_render_worker.py FD [PARENT]``."""
    if len(argv) > 2:
        _die_with_parent(int(argv[2]))
    # MuJoCo and OSMesa may print on the standard output: keep it for the messages only, and send
    # whatever else is printed to the standard error.
    outbox = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)
    # Ctrl-C in a terminal reaches the whole process group: the gateway stops the world, which ends
    # this process (its input closes); dying first would only make the world report a lost renderer.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        os.nice(NICENESS)
    except OSError:
        pass
    try:
        serve(int(argv[1]), sys.stdin.buffer, outbox)
    except BrokenPipeError:
        pass  # the parent went away: nothing left to answer
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
