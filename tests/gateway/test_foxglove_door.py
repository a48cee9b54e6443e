"""Issue 29, items 1, 2 and 6: the live view behind the gateway's door, within its budgets, over real sockets.

A hostile client on this machine (the issue's curl repro: ``Origin: https://evil.example``,
``Host: evil.example``), a client without the token, one viewer too many, a viewer that never
reads, and a connection reset in the middle: each is refused or dropped as the gateway refuses
an HTTP request, while the viewers that play by the rules go on streaming.  A page of another
site in Chromium can no longer stream (heavy: run once, on the default Python).
"""

from __future__ import annotations

import asyncio
import importlib.util
import json
import logging
import re
import socket
import struct
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import aiohttp
import pytest
from aiohttp import web

from aiogenomix.gateway import GatewayConfig, serve
from aiogenomix.gateway.__main__ import parse_args

from ._browser import browser_page, needs_browser

pytestmark = pytest.mark.skipif(importlib.util.find_spec("foxglove") is None, reason="needs the Foxglove SDK")

TOKEN = "s3cret"
UPGRADE = {"Connection": "Upgrade", "Upgrade": "websocket", "Sec-WebSocket-Version": "13",
           "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ==", "Sec-WebSocket-Protocol": "foxglove.sdk.v1"}


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@asynccontextmanager
async def view(load: tuple[str, ...] = ("demo",), **settings: Any) -> AsyncIterator[tuple[str, int]]:
    """A gateway with the live view on a free port and *load* loaded; yields its URL and the view's port."""
    port = free_port()
    config = GatewayConfig.of(port=0, audio_socket_port=0, foxglove_port=port, preload=list(load), **settings)
    async with serve(config) as url:
        yield url, port
        # Unloaded one by one, each to its end: the gateway's own shutdown gives them a second in all,
        # which a busy machine may not leave a world.
        async with aiohttp.ClientSession(base_url=url, headers=_authorization(settings)) as http:
            for name in reversed(load):
                async with http.get(f"/unload/{name}") as unloaded:
                    assert unloaded.status == 200, await unloaded.text()


def _authorization(settings: dict[str, Any]) -> dict[str, str]:
    return {"Authorization": f"Bearer {settings['token']}"} if settings.get("token") else {}


async def handshake(port: int, headers: dict[str, str], path: str = "/") -> tuple[int, dict[str, Any]]:
    """A WebSocket handshake written by hand (as curl sends it): the status, and the refusal's body or the
    first message (``serverInfo``) after a 101."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        fields = {"Host": f"127.0.0.1:{port}", **UPGRADE, **headers}
        writer.write(f"GET {path} HTTP/1.1\r\n".encode()
                     + b"".join(f"{k}: {v}\r\n".encode() for k, v in fields.items() if v is not None) + b"\r\n")
        head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 30)
        status = int(head.split(b" ", 2)[1])
        if status != 101:
            length = int(re.search(rb"(?i)content-length: *(\d+)", head).group(1))  # type: ignore[union-attr]
            return status, json.loads(await reader.readexactly(length))
        first, size = await reader.readexactly(2)
        assert first == 0x81  # one whole text message
        size = struct.unpack("!H", await reader.readexactly(2))[0] if size == 126 else size
        return status, json.loads(await reader.readexactly(size))
    finally:
        writer.close()


async def test_the_issues_repro_is_refused_and_programs_on_this_machine_still_connect() -> None:
    async with view() as (_, port):
        # The issue's repro: a page of another site, reached through a name its attacker points here.
        status, body = await handshake(port, {"Origin": "https://evil.example", "Host": "evil.example"})
        assert status == 403 and body["ex"] == "::genomix::forbidden", body
        assert "evil.example" in body["message"] and "--allowed-host" in body["message"]
        # Each rule alone: a rebinding name; a page of another site (a sandboxed frame's "null" too).
        status, body = await handshake(port, {"Host": "evil.example"})
        assert status == 403 and "--allowed-host" in body["message"]
        for origin in ("https://evil.example", "null", f"http://127.0.0.1:{port + 1}"):
            status, body = await handshake(port, {"Origin": origin})
            assert status == 403 and "--allow-origin" in body["message"], (origin, body)
        # A program (no Origin), by the address or by localhost, is served: serverInfo at once.
        for host in (f"127.0.0.1:{port}", f"localhost:{port}"):
            status, info = await handshake(port, {"Host": host})
            assert status == 101 and info["op"] == "serverInfo", info


async def test_an_allowed_origin_and_an_allowed_name_are_served() -> None:
    async with view(allowed_origins=["https://lab.example"], allowed_hosts=["robot.lab.example"]) as (_, port):
        status, info = await handshake(port, {"Origin": "https://lab.example", "Host": "robot.lab.example"})
        assert status == 101 and info["op"] == "serverInfo"
        status, _ = await handshake(port, {"Origin": "https://evil.example", "Host": "robot.lab.example"})
        assert status == 403


async def test_the_token_is_needed_in_a_header_or_in_the_url() -> None:
    import websockets

    async with view(token=TOKEN) as (_, port):
        address = f"ws://127.0.0.1:{port}"
        for url, headers in ((address, {}), (f"{address}/?token=wrong", {}),
                             (address, {"Authorization": "Bearer wrong"}), (f"{address}/?token=", {})):
            status, body = await handshake(port, headers, path=url.removeprefix(address) or "/")
            assert status == 401 and body["ex"] == "::genomix::unauthorized", (url, headers, body)
        # The token twice is a parameter given twice, as on the HTTP door; a parameter the view does
        # not take is refused by name.
        status, body = await handshake(port, {}, path=f"/?token={TOKEN}&token={TOKEN}")
        assert status == 400 and body["ex"] == "::genomix::bad_parameter"
        status, body = await handshake(port, {}, path=f"/?token={TOKEN}&tokn=x")
        assert status == 400 and "'tokn'" in body["message"]
        # A viewer puts the token in the URL (it cannot set a header on a WebSocket); a program may use the header.
        for url, headers in ((f"{address}/?token={TOKEN}", {}), (address, {"Authorization": f"Bearer {TOKEN}"})):
            async with websockets.connect(url, subprotocols=["foxglove.websocket.v1"],  # type: ignore[list-item]
                                          additional_headers=headers) as viewer:
                info = json.loads(await asyncio.wait_for(viewer.recv(), 30))
                assert info["op"] == "serverInfo" and info["name"] == "aiogenomix"
                advertised = json.loads(await asyncio.wait_for(viewer.recv(), 30))
                assert "/demo/Mobile" in {c["topic"] for c in advertised["channels"]}
        # The token does not open the door to a page of another site, nor to a rebinding name.
        status, _ = await handshake(port, {"Origin": "https://evil.example"}, path=f"/?token={TOKEN}")
        assert status == 403


async def test_viewers_are_counted_and_one_too_many_is_told_the_bound() -> None:
    import websockets

    async with view(max_viewers=2) as (_, port):
        address = f"ws://127.0.0.1:{port}"
        first = await websockets.connect(address, subprotocols=["foxglove.sdk.v1"])  # type: ignore[list-item]
        async with websockets.connect(address, subprotocols=["foxglove.sdk.v1"]):  # type: ignore[list-item]
            status, body = await handshake(port, {})
            assert status == 429 and body["ex"] == "::genomix::too_many_viewers"
            assert "--max-viewers 2" in body["message"], body
            await first.close()
            # The place is free once the first has gone: the server ends its side, then counts it out.
            status, info = await wait_for_status(port, 101)
            assert info["op"] == "serverInfo"


async def wait_for_status(port: int, wanted: int) -> tuple[int, dict[str, Any]]:
    """Handshake until the answer is *wanted* (the server frees a place when it has ended a connection)."""
    for _ in range(200):
        status, body = await handshake(port, {})
        if status == wanted:
            return status, body
        await asyncio.sleep(0.05)  # the server's side of a closed connection ends in the next few turns
    raise AssertionError(f"no {wanted} within 10 s")


async def test_a_viewer_that_never_reads_is_dropped_within_its_budget_while_another_streams(
        caplog: pytest.LogCaptureFixture) -> None:
    import websockets

    pytest.importorskip("mujoco")
    budget = 1 << 20
    caplog.set_level(logging.INFO, logger="aiogenomix.gateway._foxglove")
    async with view(("world", "kemarcapture"), viewer_bytes=budget) as (url, port):
        async with aiohttp.ClientSession(base_url=url) as http:
            async with http.get("/module/kemarcapture/send/StartCapture",
                                params={"input": '{"device":"sim","Port_chunks":200}'}):
                pass
        address = f"ws://127.0.0.1:{port}"
        # The stalled viewer's socket takes little (a small receive buffer) and its client stops reading
        # after one message: what it does not read waits in the gateway, against its budget.
        stalled_socket = socket.socket()
        stalled_socket.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled_socket.connect(("127.0.0.1", port))
        async with websockets.connect(address, subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                                      max_size=None, close_timeout=1) as viewer, \
                websockets.connect(address, subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                                   sock=stalled_socket, max_queue=1, close_timeout=0.1) as stalled:
            channels = await advertised(viewer, {"/world/kemar_camera_left", "/kemarcapture/Port"})
            everything = await advertised(stalled, {"/world/kemar_camera_left", "/kemarcapture/Port"})
            # The stalled viewer asks for everything (three cameras, the laser, the audio...) and never reads.
            await stalled.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": n, "channelId": c["id"]} for n, c in enumerate(everything.values())]}))
            await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": 1, "channelId": channels["/world/kemar_camera_left"]["id"]},
                {"id": 2, "channelId": channels["/kemarcapture/Port"]["id"]}]}))

            def dropped() -> list[logging.LogRecord]:
                return [r for r in caplog.records if "dropped" in r.getMessage()]

            # The reader reads on: each message it gets is a moment to look at the log again.
            received = 0
            while not dropped():
                await asyncio.wait_for(viewer.recv(), 30)
                received += 1
                assert received < 5000, "the stalled viewer was never dropped"
            [line] = dropped()
            assert line.levelno == logging.INFO and "--max-viewer-bytes" in line.getMessage()
            amount, unit = re.search(r"holds ([\d.]+) (KiB|MiB)", line.getMessage()).groups()  # type: ignore[union-attr]
            held = float(amount) * (1024 if unit == "KiB" else 1 << 20)
            # Within the budget and one message (the one that passed it: a camera picture is 256 KiB), as
            # the line says it (to a tenth of a MiB).
            assert budget < held + 0.05 * (1 << 20) and held <= budget + 300 * 1024, line.getMessage()
            # The reader goes on: pictures and audio keep coming after the drop.
            kinds = set()
            while kinds != {1, 2}:
                frame = await asyncio.wait_for(viewer.recv(), 30)
                if isinstance(frame, bytes) and frame[0] == 1:
                    kinds.add(int.from_bytes(frame[1:5], "little"))
            # The stalled viewer's connection was cut: what it reads now ends in a closed connection.
            with pytest.raises(websockets.ConnectionClosed):
                for _ in range(10_000):
                    await asyncio.wait_for(stalled.recv(), 30)
        assert len(dropped()) == 1  # logged once


async def advertised(viewer: Any, topics: set[str]) -> dict[str, dict[str, Any]]:
    """Read messages until every topic of *topics* is advertised; return the channels by topic."""
    channels: dict[str, dict[str, Any]] = {}
    while not topics <= set(channels):
        message = await asyncio.wait_for(viewer.recv(), 30)
        if isinstance(message, str) and json.loads(message)["op"] == "advertise":
            channels.update({c["topic"]: c for c in json.loads(message)["channels"]})
    return channels


async def test_a_reset_connection_or_a_bad_message_logs_no_error(caplog: pytest.LogCaptureFixture) -> None:
    import websockets

    caplog.set_level(logging.DEBUG)
    async with view() as (_, port):
        for _ in range(3):
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            writer.write(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                         + b"".join(f"{k}: {v}\r\n".encode() for k, v in UPGRADE.items()) + b"\r\n")
            assert (await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 30)).startswith(b"HTTP/1.1 101")
            # Reset, not closed: the server learns of it in the middle of its stream.
            writer.get_extra_info("socket").setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            writer.transport.abort()
        # A request no HTTP parser takes (a header given twice that may not be, a bare line).
        for garbage in (b"GET / HTTP/1.1\r\nHost: a\r\nHost: b\r\n\r\n", b"\x16\x03\x01 not http\r\n\r\n"):
            reader, writer = await asyncio.open_connection("127.0.0.1", port)
            try:
                writer.write(garbage)
                assert re.match(rb"HTTP/1\.[01] 400 ", await asyncio.wait_for(reader.read(), 30))
            finally:
                writer.close()
        async with websockets.connect(f"ws://127.0.0.1:{port}",  # type: ignore[list-item]
                                      subprotocols=["foxglove.sdk.v1"]) as viewer:
            await advertised(viewer, {"/demo/Mobile"})
            for bad in ("not json", '{"op": "subscribe"}', '{"op": "subscribe", "subscriptions": [{"id": true, '
                        '"channelId": 1}]}', '{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 999}]}',
                        '{"op": "setParameters", "parameters": []}', '[1, 2]'):
                await viewer.send(bad)
                status = json.loads(await asyncio.wait_for(viewer.recv(), 30))
                assert status["op"] == "status" and status["level"] in (1, 2) and status["message"], status
            await viewer.send(b"\x02binary")
            assert json.loads(await asyncio.wait_for(viewer.recv(), 30))["op"] == "status"
    # Nothing above WARNING (and nothing of the view above DEBUG): the client's doing is not a fault.
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], caplog.text
    assert not [r for r in caplog.records if r.name.startswith("aiogenomix.gateway._foxglove")
                and r.levelno > logging.DEBUG and "listening" not in r.getMessage()], caplog.text


@needs_browser
async def test_a_page_of_another_site_cannot_stream_in_chromium() -> None:
    """The issue's page: another site's script opens the view; only an allowed origin (with the token) streams."""
    async def page_of_another_site(_: web.Request) -> web.Response:
        return web.Response(text=PAGE, content_type="text/html")

    page_server = web.Application()
    page_server.router.add_get("/", page_of_another_site)
    runner = web.AppRunner(page_server, access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    page_port = site._server.sockets[0].getsockname()[1]  # type: ignore[union-attr]
    other_site = f"http://127.0.0.1:{page_port}"
    try:
        for allowed, expected in (([], "refused"), ([other_site], "streamed")):
            async with view(token=TOKEN, allowed_origins=allowed) as (_, port), browser_page() as page:
                await page.goto(f"{other_site}/#ws://127.0.0.1:{port}/?token={TOKEN}")
                await page.wait_for_function("window.outcome !== undefined", timeout=30_000)
                outcome, messages = await page.evaluate("[window.outcome, window.messages]")
                assert outcome == expected, (allowed, outcome, messages)
                assert (messages > 0) == (expected == "streamed")
    finally:
        await runner.cleanup()


#: Another site's page: it opens the view named in its URL's fragment and says whether it streamed.
PAGE = """<!doctype html><title>another site</title><script>
window.messages = 0;
const socket = new WebSocket(location.hash.slice(1), ["foxglove.sdk.v1"]);
socket.onmessage = () => { window.messages += 1; if (window.messages >= 2) window.outcome = "streamed"; };
socket.onerror = () => { window.outcome = window.outcome || "refused"; };
socket.onclose = () => { window.outcome = window.outcome || "refused"; };
</script>"""


@pytest.mark.parametrize(("argv", "refused"), [
    (["--foxglove", "70000"], "0 to 65535"),
    (["--foxglove", "8765", "--max-viewers", "0"], "--max-viewers"),
    (["--foxglove", "8765", "--max-viewer-bytes", "0"], "--max-viewer-bytes"),
])
def test_the_view_s_settings_are_checked_on_the_command_line(
        argv: list[str], refused: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        parse_args(argv)
    assert refused in capsys.readouterr().err


def test_the_view_binds_loopback_unless_asked_and_takes_its_budgets() -> None:
    assert parse_args(["--foxglove", "8765"]).view.foxglove_host == "127.0.0.1"
    # Beyond this machine with a token: the view checks it, as the HTTP door does.
    config = parse_args(["--foxglove", "8765", "--foxglove-host", "0.0.0.0", "--token", TOKEN,
                         "--max-viewers", "3", "--max-viewer-bytes", "8M"])
    assert (config.view.foxglove_host, config.view.max_viewers, config.view.viewer_bytes) == ("0.0.0.0", 3, 8 << 20)

