"""The virtual robots' world: camera frames per second, event-loop stalls while rendering, other services' latency.

Three figures of issue 10: frames per second of 256×256 cameras rendered together (1, 2, 4), the
event loop's worst stall while the world renders at full rate (target < 10 ms), and the round trip of
another component's service with the world running, against without (target: within 1.5×).
"""

from __future__ import annotations

import asyncio
import time

from aiogenomix.clients import aconnect
from aiogenomix.components.core import ComponentHost, RealClock

from ._common import Result, server, summary, verdict

#: The model's cameras, in the order they are added.
CAMERAS = ("wide_stereo_l", "kemar_eye_left", "kemar_eye_right", "wide_stereo_r")
SIZE = 256


async def _fps(cameras: int, seconds: float) -> float:
    """Frames per second of each camera when *cameras* render together, back to back."""
    from aiogenomix.components.world._render import SensorRenderer
    from aiogenomix.components.world._sim import Simulation

    sim = Simulation(SIZE, SIZE)
    renderer = SensorRenderer(sim.mujoco, sim.model, SIZE, SIZE)
    try:
        await renderer.open()
        await renderer.render(sim.snapshot(), CAMERAS[:cameras])  # warm-up
        rounds, started = 0, time.perf_counter()
        while time.perf_counter() - started < seconds:
            await renderer.render(sim.snapshot(), CAMERAS[:cameras])
            rounds += 1
        return rounds / (time.perf_counter() - started)
    finally:
        await renderer.aclose()


async def _lateness(seconds: float) -> list[float]:
    """How late a 1 ms timer fires, over *seconds*."""
    late, started = [], time.perf_counter()
    while time.perf_counter() - started < seconds:
        before = time.perf_counter()
        await asyncio.sleep(0.001)
        late.append(max(0.0, time.perf_counter() - before - 0.001))
    return late


async def _stalls(seconds: float) -> dict[str, float]:
    """Timer lateness while a world renders its cameras and laser at up to 50 frames per second, and without."""
    idle = await _lateness(seconds)
    async with ComponentHost(clock=RealClock()) as host:
        world = await host.load("world", ["-size", f"{SIZE}x{SIZE}", "-rate", "50"])
        await world.pr2_video.wait_published()  # type: ignore[attr-defined]
        first, started = world.pr2_video.version, time.perf_counter()  # type: ignore[attr-defined]
        late = await _lateness(seconds)
        frames = (world.pr2_video.version - first) / (time.perf_counter() - started)  # type: ignore[attr-defined]
    return summary(late) | {"worst": max(late) * 1e3, "frames_per_second": frames,
                            "idle_p99": summary(idle)["p99"], "idle_worst": max(idle) * 1e3}


async def _round_trips(client: object, calls: int) -> dict[str, float]:
    probe = await client.load("probe")  # type: ignore[attr-defined]
    for _ in range(calls // 10):
        await probe.Stamp()
    samples = []
    for _ in range(calls):
        started = time.perf_counter()
        await probe.Stamp()
        samples.append(time.perf_counter() - started)
    return summary(samples)


async def run(seconds: float = 5.0, calls: int = 1000) -> Result:
    """Measure the three figures; *seconds* per rendering measure, *calls* service calls per case."""
    fps = {str(n): await _fps(n, seconds) for n in (1, 2, 4)}
    stalls = await _stalls(seconds)
    async with server("gateway") as (port, _):
        async with aconnect(f"127.0.0.1:{port}") as client:
            without = await _round_trips(client, calls)
            await client.load("world", "-size", f"{SIZE}x{SIZE}", "-rate", "10")
            await client.load("pr2")
            await client.load("morse_kemar")
            with_world = await _round_trips(client, calls)
    ratio = with_world["median"] / without["median"]
    return {"size": SIZE, "camera_fps": fps, "loop_stall": stalls, "stall_target_ms": 10.0,
            "stall_verdict": verdict(stalls["worst"], 10.0),
            "service_without_world": without, "service_with_world": with_world, "ratio": ratio,
            "target_ratio": 1.5, "verdict": verdict(ratio, 1.5)}


if __name__ == "__main__":
    import json

    print(json.dumps(asyncio.run(run(seconds=3.0, calls=300)), indent=1))


def render(r: Result) -> str:
    """The Markdown section of docs/benchmarks.md."""
    fps, stall, without, with_world = r["camera_fps"], r["loop_stall"], r["service_without_world"], \
        r["service_with_world"]
    return "\n".join([
        "## Virtual robots (world on MuJoCo)", "",
        f"Cameras of {r['size']}×{r['size']} rendered together on the world's render thread (OSMesa, CPU), "
        "back to back; frames per second of each camera:", "",
        "| cameras | frames/s each | frames/s in all |", "|---|---|---|",
        *(f"| {n} | {value:.1f} | {value * int(n):.1f} |" for n, value in fps.items()), "",
        f"Event loop while a world renders its three camera ports and laser as fast as it can "
        f"({stall['frames_per_second']:.1f} frames/s each): a 1 ms timer fires {_ms(stall['median'])} ms late "
        f"at the median, {_ms(stall['p99'])} ms at p99, {_ms(stall['worst'])} ms at worst (target "
        f"< {r['stall_target_ms']:.0f} ms: **{r['stall_verdict']}**); without the world, on the same machine at "
        f"the same time, p99 {_ms(stall['idle_p99'])} ms and worst {_ms(stall['idle_worst'])} ms. OpenGL and "
        "MuJoCo run without the GIL, but the render thread's Python between their calls holds it, and the loop "
        "then waits up to the interpreter's switch interval (5 ms) for its turn: the stall is that wait plus "
        "the machine's own noise. Rendering in a process of its own would remove the first part.", "",
        "Another component's function (`probe.Stamp`, through the gateway and the generated client):", "",
        "| | median ms | p99 ms |", "|---|---|---|",
        f"| without the world | {_ms(without['median'])} | {_ms(without['p99'])} |",
        f"| world, pr2 and morse_kemar loaded (10 frames/s) | {_ms(with_world['median'])} | "
        f"{_ms(with_world['p99'])} |", "",
        f"Ratio {r['ratio']:.2f}× (target ≤ {r['target_ratio']}×): **{r['verdict']}**.", ""])


def _ms(value: float) -> str:
    return f"{value:.2f}"
