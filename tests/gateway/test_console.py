"""The browser console: served by the gateway, valid JavaScript, built on the public protocol only."""

from __future__ import annotations

import re
import shutil
import subprocess

import aiohttp
import pytest


async def test_the_console_is_served(http: aiohttp.ClientSession, tmp_path) -> None:
    async with http.get("/console") as reply:
        assert reply.status == 200
        assert reply.headers["Content-Type"] == "text/html; charset=utf-8"
        page = await reply.text()
        assert int(reply.headers["Content-Length"]) == len(page.encode())
    script = re.search(r"<script>(.*)</script>", page, re.S).group(1)  # type: ignore[union-attr]
    async with http.get("/console/plots.js") as reply:                  # its plots, in a file of their own
        assert reply.status == 200 and reply.content_type == "application/javascript"
        plots = await reply.text()
    # Only documented endpoints, and gateway text never inserted as HTML.
    used = set(re.findall(r"`/([a-z]+)(?:/|\?|`)", script)) | set(re.findall(r'"/([a-z]+)', script))
    assert used <= {"", "session", "load", "module", "console"}, used   # console: its token exchange
    assert "innerHTML" not in script and "innerHTML" not in plots and "fetch(" not in plots
    if shutil.which("node") is None:
        pytest.skip("node is not installed: the syntax check needs it")
    for name, text in (("console.js", script), ("plots.js", plots)):
        source = tmp_path / name
        source.write_text(text)
        checked = subprocess.run(["node", "--check", str(source)], capture_output=True, text=True, check=False)
        assert checked.returncode == 0, checked.stderr


async def test_the_browsers_favicon_request_is_no_error(http: aiohttp.ClientSession) -> None:
    async with http.get("/favicon.ico") as reply:
        assert reply.status == 204
