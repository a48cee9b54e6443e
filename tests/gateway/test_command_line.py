"""Command-line flags reach the components: bus, audio device, socket port."""

from __future__ import annotations

import asyncio
import os
import signal
import sys

import aiohttp

from aiogenomix.gateway import serve
from aiogenomix.gateway.__main__ import parse_args


def test_flags_make_the_configuration() -> None:
    config = parse_args(["--host", "0.0.0.0", "--port", "0", "--can", "socketcan:can0", "--audio-device", "hw:1,0",
                         "--audio-socket-port", "9000", "--time-scale", "4", "--load", "demo", "--load",
                         "demo:-i demo2", "--components", "demo,kemar"])
    assert (config.server.host, config.server.port) == ("0.0.0.0", 0)
    assert (config.rig.can, config.rig.audio_device) == ("socketcan:can0", "hw:1,0")
    assert (config.rig.audio_socket_port, config.clock.time_scale) == (9000, 4.0)
    assert config.server.preload == ("demo", "demo:-i demo2") and config.server.components == ("demo", "kemar")
    assert config.host_settings().audio_socket_host == "0.0.0.0"
    assert config.simulated_parts() == []  # a real bus and a real sound card


async def test_the_audio_device_flag_is_the_default_shown_by_info() -> None:
    config = parse_args(["--port", "0", "--audio-device", "hw:1,0", "--audio-socket-port", "0",
                         "--load", "capture", "--load", "demo:-i demo2"])
    async with serve(config) as url, aiohttp.ClientSession() as http:
        async with http.get(f"{url}/module/capture/info") as reply:
            info = await reply.json()
        start = next(s for s in info["services"] if s["name"] == "StartCapture")
        device = next(p for p in start["parameters"] if p["name"] == "device")
        assert device["default"] == "hw:1,0"
        async with http.get(f"{url}/") as reply:
            assert (await reply.json())["loaded"] == {"capture": "capture", "demo2": "demo"}


async def _first_lines_of_a_gateway(*args: str, env: dict[str, str] | None = None) -> tuple[str, str]:
    """Start the command with *args*; its stdout's first line (once it listens) and what stderr said until then."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", "0", *args,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, env=env)
    assert process.stdout is not None and process.stderr is not None
    try:
        listening = (await asyncio.wait_for(process.stdout.readline(), 60)).decode()
    finally:
        process.send_signal(signal.SIGINT)
        _, errors = await asyncio.wait_for(process.communicate(), 30)
    return listening, errors.decode()


async def test_a_token_on_the_command_line_is_warned_about_and_the_environment_is_not() -> None:
    listening, errors = await _first_lines_of_a_gateway("--token", "s3cret")
    assert "listening" in listening and "AIOGENOMIX_TOKEN" in errors and "warning" in errors
    listening, errors = await _first_lines_of_a_gateway(env=dict(os.environ, AIOGENOMIX_TOKEN="s3cret"))
    assert "listening" in listening and "warning" not in errors
