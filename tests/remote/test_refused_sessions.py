"""A Zenoh endpoint that refuses a session, or where nothing answers, is said once, with why (Zenoh says nothing)."""

from __future__ import annotations

import asyncio
import pathlib
import sys

from aiogenomix.remote._links import why_unlinked

from ._processes import Process, free_port, start_component_host, start_gateway


async def test_a_gateway_whose_password_the_robot_refuses_says_so_once(tmp_path: pathlib.Path,
                                                                        started: list[Process]) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    users = tmp_path / "users.txt"
    users.write_text("gateway:the-right-one\n")
    robot = tmp_path / "robot1.json5"
    robot.write_text(f'{{transport: {{auth: {{usrpwd: {{dictionary_file: "{users}"}}}}}}}}')
    wrong = tmp_path / "gateway.json5"
    wrong.write_text('{transport: {auth: {usrpwd: {user: "gateway", password: "a-wrong-one"}}}}')
    started.append(await start_component_host(["demo"], listen=endpoint, extra=["--zenoh-config", str(robot)]))
    gateway, _ = await start_gateway([endpoint], extra=["--zenoh-config", str(wrong)], drain=False)
    started.append(gateway)
    said = await gateway.line_matching(r"WARNING .*no Zenoh link to (\S+) after [\d.]+ s: (.*)", timeout=60)
    assert said.group(1) == endpoint
    assert said.group(2).startswith("it accepts connections but refused this Zenoh session: check the user and "
                                    "password"), said.group(0)
    # Once: Zenoh keeps trying every second, the log does not.
    await gateway.end()
    assert gateway.process.stderr is not None
    rest = (await gateway.process.stderr.read()).decode()
    assert "no Zenoh link" not in rest, rest


def test_an_endpoint_where_nothing_listens_is_told_from_a_refusal() -> None:
    assert why_unlinked(f"tcp/127.0.0.1:{free_port()}").startswith("nothing answers there (Connection refused)")
    assert why_unlinked("udp/127.0.0.1:7447") == "no link yet"


async def test_a_zenoh_client_that_reaches_no_router_says_why_and_exits(tmp_path: pathlib.Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    client = tmp_path / "client.json5"
    client.write_text(f'{{mode: "client", connect: {{endpoints: ["{endpoint}"]}}}}')
    gateway = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--zenoh-config", str(client),
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.DEVNULL, stderr=asyncio.subprocess.PIPE)
    _, err = await asyncio.wait_for(gateway.communicate(), 60)
    assert gateway.returncode == 1
    assert f"no link to {endpoint}: nothing answers there" in err.decode(), err.decode()
