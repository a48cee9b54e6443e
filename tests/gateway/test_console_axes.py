"""What a researcher reads off the console's plots (issue 34): axes with units, a range that follows, dials.

In Debian's chromium, one gateway and one page: the head's azimuth and speed over time, the audio's
waveform and level meter, a camera's picture, binauloc's estimates on a dial, each with its axis labels
and units as the page shows them.  A screenshot of each view is written to AIOGENOMIX_SHOTS when set (to
look at them).
"""

from __future__ import annotations

import asyncio
import os
import pathlib
from collections.abc import AsyncIterator
from typing import Any

import pytest

from aiogenomix.clients import aconnect
from aiogenomix.components.core import ComponentHost, ScaledClock
from aiogenomix.gateway import GatewayConfig, serve

from ..conftest import TEST_CAN_TIMEOUT
from ._browser import browser_page, needs_browser
from ._console_camera import Camera

pytestmark = [needs_browser, pytest.mark.timeout(300)]
WAIT = 30_000


#: Real time: the homing passes the limit (-179.6°, then back to the centre) in 0.4 s, which the page's
#: reads (ten a second) must see, as a person watching it does.
TIME_SCALE = 1.0


@pytest.fixture
async def gateway_with_camera() -> AsyncIterator[str]:
    config = GatewayConfig.of(port=0, time_scale=TIME_SCALE, audio_socket_port=0, can_timeout=TEST_CAN_TIMEOUT)
    async with ComponentHost(clock=ScaledClock(TIME_SCALE), settings=config.host_settings()) as host:
        host.register("camera", Camera)
        async with serve(config, host) as url:
            yield url


@pytest.fixture
async def page(gateway_with_camera: str) -> AsyncIterator[Any]:
    async with browser_page(viewport={"width": 1400, "height": 1000}) as opened:
        yield opened


def port(page: Any, name: str) -> Any:
    return page.locator(f'details[data-port="{name}"]')


async def labels(locator: Any) -> list[list[str]]:
    """The axis labels each matching element declares (x, y, or a dial's one axis)."""
    return await locator.evaluate_all(
        "els => els.map(e => [e.dataset.xLabel, e.dataset.yLabel, e.dataset.axisLabel].filter(Boolean))")


async def shoot(page: Any, locator: Any, name: str) -> None:
    await locator.scroll_into_view_if_needed()
    if os.environ.get("AIOGENOMIX_SHOTS"):
        await locator.screenshot(path=str(pathlib.Path(os.environ["AIOGENOMIX_SHOTS"], f"{name}.png")))


async def open_module(page: Any, url: str, instance: str) -> None:
    """Open the console on *instance*, as a bookmark of it does (a new page load, not a change of its #)."""
    await page.goto("about:blank")
    await page.goto(f"{url}/console#{instance}")
    await page.locator("h1", has_text=instance).wait_for(timeout=WAIT)


async def test_axes_with_units_for_the_head_audio_a_camera_and_binaulocs_dial(
        page: Any, gateway_with_camera: str) -> None:
    url = gateway_with_camera
    async with aconnect(url) as rig:
        head = await rig.load("kemarcapture")

        # The head: azimuth and speed over time, in degrees and deg/s; the dial shows where it looks.
        await open_module(page, url, "kemarcapture")
        state = port(page, "currentState")
        series = state.locator(".series")
        await series.first.wait_for(timeout=WAIT)
        assert await labels(series) == [["time (s)", "position (deg)"], ["time (s)", "speed (deg/s)"]]
        dial = state.locator("canvas.dial")
        assert await labels(dial) == [["azimuth (deg, + = left)"]]
        position = series.first
        await head.Homing()                                  # to both limits (±179.6°), then the centre
        await head.StartCapture(device="sim", ack=True)
        await state.locator(".dial-view .needle", has_text="position: 0 deg").wait_for(timeout=WAIT)
        await page.wait_for_function("e => Number(e.dataset.range.split(' ')[0]) < -100",
                                     arg=await position.element_handle(), timeout=WAIT)

        # Moves of ±60° after the homing: once the homing is older than the seconds the range follows,
        # the value axis holds the moves, not the limits.
        moving = asyncio.Event()

        async def sweep() -> None:
            while True:
                for target in (60, -60):
                    await head.MoveAbsolutePosition(target, 200)
                    moving.set()

        sweeping = asyncio.create_task(sweep())
        try:
            await moving.wait()
            await page.wait_for_function(
                "e => { const [low, high] = e.dataset.range.split(' ').map(Number); "
                "return low >= -100 && high <= 100 && high - low >= 120; }",
                arg=await position.element_handle(), timeout=WAIT)
        finally:
            sweeping.cancel()
            await asyncio.gather(sweeping, return_exceptions=True)
        await shoot(page, state, "head")

        # A long activity shows its progress beside it: the head's position while it turns.
        turn = page.locator('details[data-service="ControlInSpeed"]')
        await turn.locator("summary").click()
        await turn.locator('input[name="velocity"]').fill("2")
        await turn.get_by_role("button", name="send").click()
        row = page.locator("#requests tr", has_text="ControlInSpeed")
        await row.locator("td", has_text="currentState.position = ").wait_for(timeout=WAIT)
        assert (await row.locator("td", has_text="currentState.position").inner_text()).endswith(" deg")
        await turn.locator("pre.result", has_text="currentState.position = ").wait_for(timeout=WAIT)
        await row.get_by_role("button", name="abort").click()
        await row.locator("td", has_text="error").wait_for(timeout=WAIT)

        # The audio: each ear over the last seconds, a time axis, a level meter in dBFS; the window's size
        # (nbframes) stays the window's whatever each incremental read brings.
        audio = port(page, "Port")
        await audio.locator("summary").click()
        await audio.get_by_role("button", name="watch").click()
        waveform = audio.locator(".waveform")
        await page.wait_for_function("e => Number(e.dataset.chunks || 0) > 5", arg=await waveform.element_handle(),
                                     timeout=WAIT)
        assert await labels(waveform) == [["time (s)"]]
        assert await labels(waveform.locator("[data-y-label]")) == [
            ["left (full scale)"], ["right (full scale)"], ["peak (dBFS)"]]
        levels = await waveform.locator("canvas.meter").evaluate("c => c.dataset.levels.split(' ').map(Number)")
        assert all(-60 < level < 0 for level in levels)          # the simulated scene, heard by both ears
        seen = set()
        for _ in range(5):
            text = await audio.locator("pre.data").inner_text()
            seen.add(next(line for line in text.splitlines() if line.startswith("nbframes:")))
            await page.wait_for_function("([e, n]) => Number(e.dataset.chunks) > n",
                                         arg=[await waveform.element_handle(),
                                              int(await waveform.get_attribute("data-chunks") or 0)], timeout=WAIT)
        assert seen == {"nbframes: 44100"}                       # 20 chunks of 2205 frames: the port's window
        await shoot(page, audio, "audio")

        # A camera: the picture with its pixel axes.
        await rig.load("camera")
        await open_module(page, url, "camera")
        frame = port(page, "Frame")
        await frame.locator("summary").click()
        await frame.get_by_role("button", name="watch").click()
        picture = frame.locator("canvas.picture")
        await page.wait_for_function("c => Number(c.dataset.frames || 0) > 0", arg=await picture.element_handle(),
                                     timeout=WAIT)
        assert await labels(picture) == [["x (px)", "y (px)"]]
        await shoot(page, frame, "camera")

        # binauloc's estimates on a dial: the azimuth (radians on the wire, degrees here), the head's, and the
        # log-likelihood of every direction as a ring.
        localiser = await rig.load("binauloc")
        await localiser.connect_port("Audio", "kemarcapture/Port")
        await localiser.LocalizeSources(ack=True)
        await open_module(page, url, "binauloc")
        azimuths = port(page, "Azimuths")
        dial = azimuths.locator("canvas.dial")
        await dial.wait_for(timeout=WAIT)
        assert await labels(dial) == [["azimuth (deg, + = left)"]]
        caption = azimuths.locator(".dial-view .caption")
        await caption.locator(".needle", has_text="headAzimuth: ").wait_for(timeout=WAIT)
        await page.wait_for_function("c => Number(c.dataset.draws || 0) > 3", arg=await dial.element_handle(),
                                     timeout=WAIT)
        await caption.locator(".ring", has_text="logLikelihood: ring").wait_for(timeout=WAIT)
        needles = await caption.locator(".needle").all_inner_texts()
        assert any(n.startswith("azimuth: ") and n.endswith(" deg (from rad)") for n in needles), needles
        assert any(n.startswith("headAzimuth: ") for n in needles), needles
        assert await labels(azimuths.locator(".series")) == [["time (s)", "azimuth (deg)"],
                                                              ["time (s)", "confidence"]]
        await shoot(page, azimuths, "binauloc")
    assert page.problems == []
