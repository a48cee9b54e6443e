"""Clients generated from ``/openapi.json`` by other people's tools move the robots where they are told.

The real generators, as users run them: openapi-python-client (package index)
and @hey-api/openapi-ts (npm), whose TypeScript client is type-checked by tsc
and run by Node; Redocly's linter with its recommended rules; Schemathesis
following the document's links; and Swagger UI served from another origin
driving a gateway with a token in Chromium.  Heavy: run once, on the default
Python (``AIOGENOMIX_HEAVY=0`` skips them), and only where Node and npm are
(``./run test`` installs them).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from aiohttp import web

from aiogenomix.gateway import GatewayConfig, serve, serve_in_thread
from tests.gateway._browser import browser_page, needs_browser

pytestmark = pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0",
                                reason="heavy: run once, on the default Python")

TOKEN = "s3cret"
HERE = Path(__file__).parent
TOOLS = HERE / "openapi_clients"
#: Where the npm tools are installed, once per virtualenv (again when their package.json changes).
NODE_HOME = Path(sys.prefix) / "openapi-clients"
#: What each generated client must read back: demo at 0.5 m, the head at 20 degrees.
MOVED = {"gotoEnded": "done", "homingEnded": "done", "moveEnded": "done", "position": 0.5, "azimuth": 20.0}


def _run(*command: str | Path, cwd: Path | None = None, timeout: float = 300) -> str:
    done = subprocess.run([str(part) for part in command], cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          stdin=subprocess.DEVNULL, check=False)
    assert done.returncode == 0, f"{' '.join(map(str, command))}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done.stdout


@pytest.fixture(scope="module")
def node_tools() -> Path:
    """The npm tools of ``openapi_clients/package.json``, installed (exact versions, no lock file)."""
    if shutil.which("npm") is None or shutil.which("node") is None:
        pytest.skip("needs node and npm (./run test installs them)")
    wanted = (TOOLS / "package.json").read_text()
    installed = NODE_HOME / ".installed"  # the package.json of the last install that ended well
    if not installed.exists() or installed.read_text() != wanted:
        shutil.rmtree(NODE_HOME, ignore_errors=True)
        NODE_HOME.mkdir(parents=True)
        (NODE_HOME / "package.json").write_text(wanted)
        _run("npm", "install", "--no-package-lock", "--no-audit", "--no-fund", "--silent", cwd=NODE_HOME,
             timeout=600)
        installed.write_text(wanted)
    return NODE_HOME


@pytest.fixture
def gateway_with_token() -> Iterator[str]:
    """A gateway with a token and a fresh demo and kemar (each client moves them from where they start)."""
    config = GatewayConfig.of(port=0, time_scale=20, audio_socket_port=0, token=TOKEN, preload=["demo", "kemar"])
    with serve_in_thread(config) as url:
        yield url


@pytest.fixture
def document(gateway_with_token: str, tmp_path: Path) -> Path:
    import urllib.request

    path = tmp_path / "openapi.json"
    with urllib.request.urlopen(f"{gateway_with_token}/openapi.json", timeout=30) as reply:  # open: no token
        path.write_bytes(reply.read())
    return path


def test_redocly_lint_finds_no_error(node_tools: Path, document: Path) -> None:
    out = _run(node_tools / "node_modules/.bin/redocly", "lint", document, "--format=json", cwd=document.parent)
    report = json.loads(out[out.index("{"):])
    assert report["totals"]["errors"] == 0, report["problems"][:5]
    assert report["totals"]["warnings"] == 0, report["problems"][:5]


def test_openapi_python_client_moves_demo_and_kemar(gateway_with_token: str, document: Path,
                                                    tmp_path: Path) -> None:
    config = tmp_path / "config.yaml"
    config.write_text("post_hooks: []\n")  # no formatter needed to use the code
    _run(sys.executable, "-m", "openapi_python_client", "generate", "--path", document, "--meta", "none",
         "--output-path", tmp_path / "client", "--config", config, cwd=tmp_path)
    shutil.copy(HERE / "_generated_python_client.py", tmp_path)
    out = _run(sys.executable, tmp_path / "_generated_python_client.py", gateway_with_token, TOKEN, cwd=tmp_path)
    assert json.loads(out) == MOVED


def test_hey_api_typescript_client_moves_demo_and_kemar(gateway_with_token: str, document: Path, node_tools: Path,
                                                        tmp_path: Path) -> None:
    shutil.copytree(TOOLS, tmp_path, dirs_exist_ok=True)
    (tmp_path / "node_modules").symlink_to(node_tools / "node_modules")
    _run(node_tools / "node_modules/.bin/openapi-ts", "-i", document, "-o", tmp_path / "src/client", cwd=tmp_path)
    _run(node_tools / "node_modules/.bin/tsc", "-p", tmp_path, cwd=tmp_path)  # strict: the client is typed
    out = _run("node", tmp_path / "dist/main.js", gateway_with_token, TOKEN, cwd=tmp_path)
    assert json.loads(out) == MOVED


def test_schemathesis_stateful_follows_the_links(gateway_with_token: str) -> None:
    import schemathesis
    from hypothesis import HealthCheck, settings
    from hypothesis.stateful import run_state_machine_as_test

    schema = schemathesis.openapi.from_url(f"{gateway_with_token}/openapi.json")
    schema.config.update(headers={"Authorization": f"Bearer {TOKEN}"})
    # Not followed: what unloads or kills the modules under test, streams that never end, waits that may
    # last an hour, loads and sessions (checked elsewhere), the console, and genomix's GET forms of send,
    # whose input is JSON text no schema can describe (the POST forms carry the same models).
    schema = schema.exclude(path_regex=r"kill|unload|/load/|/session/|/watch/|/wait/|connect_port|"
                                       r"connect_service|abort_activity|/console|/docs")
    schema = schema.exclude(operation_id_regex=r"_query$")
    machine = schema.as_state_machine()
    assert any("200_status__GET_module_module_status_rqst" in rule for rule in dir(machine))  # links followed
    run_state_machine_as_test(machine, settings=settings(
        max_examples=int(os.environ.get("AIOGENOMIX_OPENAPI_EXAMPLES", "100")), stateful_step_count=6,
        deadline=None, database=None, suppress_health_check=list(HealthCheck)))


@pytest.fixture
async def second_origin() -> AsyncIterator[tuple[str, list[str]]]:
    """A web server of another origin, serving one page: Swagger UI pointed at the gateway named in its query."""
    page = """<!doctype html><html><head><meta charset="utf-8">
<link rel="stylesheet" href="GATEWAY/docs/swagger-ui.css"></head>
<body><div id="ui"></div><script src="GATEWAY/docs/swagger-ui-bundle.js"></script>
<script>SwaggerUIBundle({url: "GATEWAY/openapi.json", dom_id: "#ui"});</script></body></html>"""
    gateways: list[str] = []

    async def swagger(request: web.Request) -> web.Response:
        return web.Response(text=page.replace("GATEWAY", gateways[0]), content_type="text/html")

    async def no_icon(request: web.Request) -> web.Response:
        return web.Response(status=204)

    app = web.Application()
    app.router.add_get("/", swagger)
    app.router.add_get("/favicon.ico", no_icon)
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    await web.TCPSite(runner, "127.0.0.1", 0).start()
    try:
        yield f"http://127.0.0.1:{runner.addresses[0][1]}", gateways
    finally:
        await runner.cleanup()


@needs_browser
async def test_swagger_ui_of_another_origin_drives_a_gateway_with_a_token(
        second_origin: tuple[str, list[str]]) -> None:
    origin, gateways = second_origin
    config = GatewayConfig.of(port=0, time_scale=20, audio_socket_port=0, token=TOKEN, allowed_origins=[origin],
                           preload=["demo"])
    async with serve(config) as gateway, browser_page() as page:
        gateways.append(gateway)
        await page.goto(origin)
        # Authorize: the token, once, for every operation.
        await page.click("button.authorize")
        await page.fill(".modal-ux input[type=text], .modal-ux input[type=password]", TOKEN)
        await page.click(".modal-ux .auth-btn-wrapper button.authorize")
        await page.click(".modal-ux button.btn-done")
        moved = await _try_it_out(page, "demo-demo_GotoPosition", body='{"posRef": 0.5}')
        assert moved["status"] == "sent"
        auth = {"Authorization": f"Bearer {TOKEN}"}
        async with aiohttp.ClientSession(base_url=gateway, headers=auth) as http:
            async with http.get(f"/module/demo/wait/{moved['id']}") as reply:
                assert (await reply.json())["status"] == "done"
        read = await _try_it_out(page, "demo-demo_read_Mobile")
        assert read["Mobile"]["position"] == 0.5
        assert page.problems == []


async def _try_it_out(page: Any, operation: str, body: str | None = None) -> Any:
    """Open *operation* in Swagger UI, try it out (with *body*), execute it, and return its reply's JSON."""
    block = page.locator(f"#operations-{operation}")
    await block.locator(".opblock-summary").click()
    await block.locator("button.try-out__btn").click()
    if body is not None:
        await block.locator("textarea.body-param__text").fill(body)
    await block.locator("button.execute").click()
    status = block.locator(".live-responses-table .response .response-col_status").first
    await status.wait_for()
    assert (await status.inner_text()).strip() == "200"
    text = await block.locator(".live-responses-table .response-col_description pre.microlight").first.inner_text()
    return json.loads(text)
