"""The console's plotting library (uPlot) is the npm release named in its README, shipped and served by the gateway."""

from __future__ import annotations

import hashlib
import importlib.resources
import re

import aiohttp
import pytest

from aiogenomix.gateway import GatewayConfig

from ..conftest import TEST_TIME_SCALE

#: What gateway/vendor/uplot/README.md says was copied from the npm package uplot 1.6.32.
VERSION = "1.6.32"
HASHES = {
    "uPlot.iife.min.js": "19c8d4c6ad88929a79f4ae49d6f7161566dfd0ba3d15cc495e974f787eb78f1f",
    "uPlot.min.css": "df630c6a8d6f8eeaff264b50f73ce5b114f646ffd9a0bb74f049b0a00135fa04",
    "LICENSE": "8f989229699b4fe2f1a0432d0e9edc338a8a911e250e2d1b01ecd770a5f5b1bd",
}


def vendored(name: str) -> bytes:
    # Read from the installed package: a file the package data leaves out is missing here too.
    return (importlib.resources.files("aiogenomix.gateway") / "vendor" / "uplot" / name).read_bytes()


def test_the_vendored_files_are_the_release_the_readme_names() -> None:
    for name, digest in HASHES.items():
        assert hashlib.sha256(vendored(name)).hexdigest() == digest, name
    assert vendored("uPlot.iife.min.js").startswith(f"/*! https://github.com/leeoniya/uPlot (v{VERSION}) */".encode())
    assert b"MIT License" in vendored("LICENSE")
    readme = vendored("README.md").decode()
    assert f"`uplot` {VERSION}" in readme and "npm pack uplot@VERSION" in readme
    for name, digest in HASHES.items():
        assert re.search(rf"`{re.escape(name)}`.*`{digest}`", readme), name


async def test_the_gateway_serves_them_without_the_token(http: aiohttp.ClientSession) -> None:
    for name, kind in (("uPlot.iife.min.js", "application/javascript"), ("uPlot.min.css", "text/css")):
        async with http.get(f"/console/{name}") as reply:
            assert reply.status == 200 and reply.content_type == kind
            assert await reply.read() == vendored(name)
    async with http.get("/console/LICENSE") as reply:          # only the two files the page loads are open
        assert reply.status == 401
    async with http.get("/console/LICENSE", headers={"Authorization": "Bearer s3cret"}) as reply:
        assert reply.status == 404
    async with http.get("/console") as page:
        body = await page.read()
        assert b'<script src="/console/uPlot.iife.min.js"></script>' in body
        assert b'<script src="/console/plots.js"></script>' in body
        assert b'<link rel="stylesheet" href="/console/uPlot.min.css">' in body
        assert "script-src 'self' 'sha256-" in page.headers["Content-Security-Policy"]


@pytest.fixture
def gateway_config() -> GatewayConfig:
    return GatewayConfig.of(port=0, time_scale=TEST_TIME_SCALE, audio_socket_port=0, token="s3cret")
