"""The seed's Figure 4.3 session, typed with curl against a real gateway."""

from __future__ import annotations

import asyncio
import json
import shutil

import pytest

pytestmark = pytest.mark.skipif(shutil.which("curl") is None, reason="curl is installed by ./run")


async def curl(url: str) -> str:
    process = await asyncio.create_subprocess_exec("curl", "-sS", "--fail-with-body", url,
                                                   stdout=asyncio.subprocess.PIPE)
    out, _ = await process.communicate()
    assert process.returncode == 0, out
    return out.decode()


async def next_request_event(lines: asyncio.StreamReader) -> dict:
    event = ""
    while True:
        line = (await asyncio.wait_for(lines.readline(), 10)).decode().rstrip("\n")
        if line.startswith("event: "):
            event = line.removeprefix("event: ")
        elif line.startswith("data: ") and event == "request":
            return json.loads(line.removeprefix("data: "))


async def test_figure_4_3_session_with_curl(gateway: str) -> None:
    session = await curl(f"{gateway}/session/start?s=")
    assert session
    listen = await asyncio.create_subprocess_exec("curl", "-sS", "-N", f"{gateway}/session/listen?s={session}",
                                                  stdout=asyncio.subprocess.PIPE)
    try:
        assert await curl(f"{gateway}/load/demo?s={session}&argv=") == "demo"

        # ::demo::GotoPosition 0.5 — blocking: wait for its "done".
        goto = f"{gateway}/module/demo/send/GotoPosition?s={session}&input="
        sent = json.loads(await curl(goto + "%7B%22posRef%22:0.5%7D"))
        assert sent == {"id": "demo::0", "status": "sent"}
        assert await next_request_event(listen.stdout) == sent
        assert await next_request_event(listen.stdout) == {"id": "demo::0", "status": "done", "output": {}}
        assert await curl(f"{gateway}/module/demo/clean/demo::0?s={session}") == ""

        # ::demo::GotoPosition 1 & — non-blocking: the reply says "sent", the stream says "sent" then "done".
        reply = json.loads(await curl(goto + "%7B%22posRef%22:1%7D"))
        assert reply == {"id": "demo::0", "status": "sent"}
        assert await next_request_event(listen.stdout) == {"id": "demo::0", "status": "sent"}
        assert await next_request_event(listen.stdout) == {"id": "demo::0", "status": "done", "output": {}}

        # ::demo::Mobile — where the robot really is.
        assert await curl(f"{gateway}/module/demo/read/Mobile?s={session}") == '{"Mobile":{"position":1.0,"speed":0.0}}'
    finally:
        listen.kill()
        await listen.wait()
