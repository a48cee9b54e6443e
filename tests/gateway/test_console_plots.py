"""The console as a person uses it, in Debian's chromium (issue 13): forms, events, plots, pictures, audio.

One browser and one gateway serve every step of a test: each step waits on what
the page shows (Playwright's locators), never on time.  The screenshot of the
README is taken here: it is written to docs/images/ when missing or when
AIOGENOMIX_SCREENSHOT=1 (so that a run of the suite leaves the tree clean).
"""

from __future__ import annotations

import os
import pathlib
from collections.abc import AsyncIterator
from typing import Any

import aiohttp
import pytest

from aiogenomix.components.core import ComponentHost, ScaledClock
from aiogenomix.gateway import GatewayConfig, serve

from ..conftest import TEST_CAN_TIMEOUT, TEST_TIME_SCALE
from ._console_camera import Camera
from ._browser import browser_page, needs_browser

pytestmark = needs_browser
SCREENSHOT = pathlib.Path(__file__).parents[2] / "docs" / "images" / "console.png"
WAIT = 20_000


@pytest.fixture
async def gateway_with_camera() -> AsyncIterator[str]:
    config = GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, can_timeout=TEST_CAN_TIMEOUT)
    async with ComponentHost(clock=ScaledClock(TEST_TIME_SCALE), settings=config.host_settings()) as host:
        host.register("camera", Camera)
        async with serve(config, host) as url:
            yield url


@pytest.fixture
async def page(gateway_with_camera: str) -> AsyncIterator[Any]:
    async with browser_page(viewport={"width": 1400, "height": 900}) as opened:
        yield opened


async def load(page: Any, name: str) -> None:
    await page.locator(f'#available li[data-component="{name}"]').get_by_role("button", name="load").click()
    await page.locator("h1", has_text=name).wait_for(timeout=WAIT)


def service(page: Any, name: str) -> Any:
    return page.locator(f'details[data-service="{name}"]')


def port(page: Any, name: str) -> Any:
    return page.locator(f'details[data-port="{name}"]')


async def counter_above(locator: Any, attribute: str, value: int) -> None:
    """Wait until the element's data-ATTRIBUTE counter is above *value* (the page drew that often)."""
    await locator.page.wait_for_function(
        f"([e, v]) => Number(e.dataset.{attribute} || 0) > v", arg=[await locator.element_handle(), value],
        timeout=WAIT)


async def test_forms_events_plots_pictures_and_audio(page: Any, gateway_with_camera: str) -> None:
    await page.goto(f"{gateway_with_camera}/console")
    await load(page, "demo")
    # A malformed number is refused in the form, with a message, and nothing is sent.
    goto = service(page, "GotoPosition")
    await goto.locator("summary").click()
    await goto.locator('input[name="posRef"]').fill("1e")
    await goto.get_by_role("button", name="send").click()
    await goto.locator("pre.result", has_text='posRef: "1e" is not a number').wait_for(timeout=WAIT)
    assert await page.locator("#requests tr").count() == 0
    # Plot the robot's position, then move it: the plot follows, the events name the service.
    mobile = port(page, "Mobile")
    await mobile.locator("summary").click()
    await mobile.locator('input[data-member="position"]').check()
    await goto.locator('input[name="posRef"]').fill("0.5")
    await goto.get_by_role("button", name="send").click()
    await page.locator("#events .event", has_text="GotoPosition done").wait_for(timeout=WAIT)
    await goto.locator("pre.result", has_text="done").wait_for(timeout=WAIT)
    await mobile.locator("pre.data", has_text="position: 0.5").wait_for(timeout=WAIT)
    await counter_above(mobile.locator(".series"), "points", 2)
    # An exception of the component reads as a sentence with its detail.
    await goto.locator('input[name="posRef"]').fill("3")
    await goto.get_by_role("button", name="send").click()
    await goto.locator("pre.result", has_text="::demo::TOO_FAR_AWAY").wait_for(timeout=WAIT)
    await goto.locator("pre.result", has_text="overshoot: 2").wait_for(timeout=WAIT)
    await page.locator("#requests tr", has_text="GotoPosition").first.get_by_role("button", name="clean").click()

    # Audio: start a capture from its form; the waveform scrolls as chunks arrive.
    await load(page, "capture")
    start = service(page, "StartCapture")
    await start.locator("summary").click()
    await start.get_by_role("button", name="send").click()
    await page.locator("#requests tr", has_text="StartCapture").locator("td", has_text="sent").wait_for(timeout=WAIT)
    audio = port(page, "Port")
    await audio.locator("summary").click()
    await audio.get_by_role("button", name="watch").click()
    await counter_above(audio.locator(".waveform"), "chunks", 3)

    # A picture port is drawn as a picture, and redrawn when it changes.
    await load(page, "camera")
    frame = port(page, "Frame")
    await frame.locator("summary").click()
    await frame.get_by_role("button", name="watch").click()
    picture = frame.locator("canvas.picture")
    await counter_above(picture, "frames", 0)
    # Drawn 8 times larger (256 pixels) beside its pixel axes: image pixel (5, 1) is a dark square's.
    assert await picture.evaluate("c => Number(c.dataset.scale)") == 8
    red = ("c => c.getContext('2d').getImageData(Number(c.dataset.left) + 5.5 * 8, Number(c.dataset.top) + 1.5 * 8,"
           " 1, 1).data[0]")
    assert await picture.evaluate(red) == 200
    shade = service(page, "Shade")
    await shade.locator("summary").click()
    await shade.locator('input[name="red"]').fill("70000")
    await shade.get_by_role("button", name="send").click()
    await shade.locator("pre.result", has_text="outside 0…65535").wait_for(timeout=WAIT)
    await shade.locator('input[name="red"]').fill("20")
    await shade.get_by_role("button", name="send").click()
    await page.wait_for_function(f"() => ({red})(document.querySelector('canvas.picture')) === 20", timeout=WAIT)

    # A place on the floor is drawn on a top-down map as it changes.
    odom = port(page, "Odom")
    await odom.locator("summary").click()
    await odom.get_by_role("button", name="watch").click()
    await counter_above(odom.locator("canvas.map"), "points", 0)
    drive = service(page, "Drive")
    await drive.locator("summary").click()
    await drive.locator('input[name="x"]').fill("2")
    await drive.get_by_role("button", name="send").click()
    await counter_above(odom.locator("canvas.map"), "points", 1)

    # Back to capture: its watch is still on, and says so.
    await page.locator("#loaded").get_by_role("button", name="capture").click()
    await port(page, "Port").get_by_role("button", name="stop watching").wait_for(timeout=WAIT)
    await counter_above(port(page, "Port").locator(".waveform"), "chunks", 6)
    await port(page, "Port").locator(".waveform").scroll_into_view_if_needed()
    shot = await page.screenshot()
    if os.environ.get("AIOGENOMIX_SHOTS"):
        pathlib.Path(os.environ["AIOGENOMIX_SHOTS"], "capture.png").write_bytes(shot)
    if os.environ.get("AIOGENOMIX_SCREENSHOT") == "1" or not SCREENSHOT.exists():
        SCREENSHOT.parent.mkdir(exist_ok=True)
        SCREENSHOT.write_bytes(shot)
    assert page.problems == []


async def test_many_long_activities_leave_the_console_responsive(page: Any, gateway_with_camera: str) -> None:
    await page.goto(f"{gateway_with_camera}/console")
    await load(page, "demo")
    # Eight requests that run until the robot crosses a point, and a watched port.
    monitor = service(page, "Monitor")
    await monitor.locator("summary").click()
    await monitor.locator('input[name="monitor"]').fill("0.9")
    for _ in range(8):
        await monitor.get_by_role("button", name="send").click()
        await monitor.get_by_role("button", name="send").wait_for(timeout=WAIT)
    await page.locator("#requests tr", has_text="Monitor").nth(7).wait_for(timeout=WAIT)
    await port(page, "Mobile").locator("summary").click()
    await port(page, "Mobile").get_by_role("button", name="watch").click()
    # A function still answers at once, and so do reads.
    speed = service(page, "GetSpeed")
    await speed.locator("summary").click()
    await speed.get_by_role("button", name="send").click()
    await speed.locator("pre.result", has_text='speedRef: "::demo::SLOW"').wait_for(timeout=WAIT)
    # One running request is aborted from its row.
    row = page.locator("#requests tr", has_text="Monitor").first
    await row.get_by_role("button", name="abort").click()
    await page.locator("#events .event", has_text="Monitor error ::genom::interrupted").wait_for(timeout=WAIT)
    # The KEMAR head's azimuth and speed are plotted as soon as its module opens.
    await load(page, "kemar")
    head = port(page, "currentState")
    await head.get_by_role("button", name="stop watching").wait_for(timeout=WAIT)
    assert await head.locator(".series").count() == 2
    await counter_above(head.locator(".series").first, "points", 1)
    # Reloading the page keeps its session: no session is left behind per load.
    for _ in range(3):
        await page.reload()
        await page.locator("#loaded").get_by_role("button", name="demo").wait_for(timeout=WAIT)
    async with aiohttp.ClientSession(base_url=gateway_with_camera) as http, http.get("/") as index:
        assert (await index.json())["sessions"] == 1
    assert page.problems == []
