"""The README's two commands work as written, and CI runs exactly the test one."""

from __future__ import annotations

import asyncio
import re
import signal
from pathlib import Path

import aiohttp

ROOT = Path(__file__).resolve().parents[2]


def readme_commands() -> list[str]:
    first_block = re.search(r"```sh\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert first_block, "the README opens with a sh block of commands"
    return [line.split("#")[0].strip() for line in first_block.group(1).splitlines() if line.strip()]


def test_readme_opens_with_the_two_commands() -> None:
    assert readme_commands() == ["./run gateway", "./run test"]


def test_ci_runs_the_readme_test_command() -> None:
    script = (ROOT / ".ci" / "run").read_text()
    assert re.search(r"^exec \./run test$", script, re.M)


async def test_gateway_command_serves_and_stops_cleanly_on_sigint() -> None:
    gateway_command = readme_commands()[0].split()
    process = await asyncio.create_subprocess_exec(
        *gateway_command, "--port", "0", "--audio-socket-port", "0", cwd=ROOT,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )
    try:
        line = (await asyncio.wait_for(process.stdout.readline(), 120)).decode()
        match = re.match(r"aiogenomix gateway listening on (http://127\.0\.0\.1:\d+)", line)
        assert match, line
        assert "simulated" in line
        async with aiohttp.ClientSession() as http:
            async with http.get(f"{match.group(1)}/load/demo") as reply:
                assert await reply.text() == "demo"
            async with http.get(f"{match.group(1)}/module/demo/send/GotoPosition",
                                params={"input": '{"posRef":0.1}'}) as reply:
                assert (await reply.json())["status"] == "sent"
        process.send_signal(signal.SIGINT)
        assert await asyncio.wait_for(process.wait(), 30) == 0
    finally:
        if process.returncode is None:
            process.kill()
            await process.wait()
