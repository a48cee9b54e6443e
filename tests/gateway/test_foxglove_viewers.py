"""Issue 34, item 2: every current viewer connects, whichever name of the protocol it offers.

A raw WebSocket client of each subprotocol (``foxglove.websocket.v1``: the protocol's
specification, ``@foxglove/ws-protocol``, Lichtblick before its ``foxglove.sdk.v1`` support;
``foxglove.sdk.v1``: the Foxglove SDK's name, newer viewers) and ``@foxglove/ws-protocol``'s own
``FoxgloveClient`` (npm, run by Node; heavy: once, on the default Python) each receive the head,
a camera and the audio, decoded with the schemas the view advertises.
"""

from __future__ import annotations

import asyncio
import base64
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from .test_foxglove_view import advertised, decoder, gateway  # noqa: F401  (the fixture)

TOPICS = ("/kemar/currentState", "/world/kemar_camera_left", "/kemarcapture/Port")
TOOLS = Path(__file__).parent / "foxglove_clients"
#: Where the npm client is installed, once per virtualenv (again when its package.json changes).
NODE_HOME = Path(sys.prefix) / "foxglove-clients"


def check_decoded(messages: dict[str, Any]) -> None:
    """What a viewer of the head, a camera and the audio must see."""
    joints = messages["/kemar/currentState"].joints
    assert [j.name for j in joints] == ["head_yaw"] and joints[0].position == pytest.approx(0.0)
    picture = messages["/world/kemar_camera_left"]
    assert (picture.width, picture.height, picture.encoding) == (256, 256, "rgba8")
    assert len(picture.data) == 256 * 256 * 4
    sound = messages["/kemarcapture/Port"]
    assert (sound.format, sound.sample_rate, sound.number_of_channels) == ("pcm-s16", 44100, 2)
    frames = len(np.frombuffer(sound.data, "<i2").reshape(-1, 2))
    assert frames and frames % 2205 == 0  # whole 50 ms chunks (two when the view was late for one)


@pytest.mark.parametrize("subprotocol", ["foxglove.websocket.v1", "foxglove.sdk.v1"])
async def test_a_raw_client_of_either_name_gets_the_head_a_camera_and_the_audio(
        gateway: tuple[str, int], subprotocol: str) -> None:  # noqa: F811
    import websockets

    _, port = gateway
    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=[subprotocol],  # type: ignore[list-item]
                                  max_size=None, close_timeout=1) as viewer:
        assert viewer.subprotocol == subprotocol
        info = json.loads(await asyncio.wait_for(viewer.recv(), 30))
        assert info["op"] == "serverInfo" and info["name"] == "aiogenomix"
        channels = await advertised(viewer, set(TOPICS))
        await viewer.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": n, "channelId": channels[topic]["id"]} for n, topic in enumerate(TOPICS)]}))
        decoded: dict[str, Any] = {}
        while len(decoded) < len(TOPICS):
            frame = await asyncio.wait_for(viewer.recv(), 30)
            if isinstance(frame, bytes) and frame[0] == 1:  # messageData: op, subscription, log time, payload
                topic = TOPICS[int.from_bytes(frame[1:5], "little")]
                decoded[topic] = decoder(channels[topic]).FromString(frame[13:])
        check_decoded(decoded)


@pytest.fixture(scope="module")
def foxglove_client() -> Path:
    """``@foxglove/ws-protocol`` and ``ws`` of ``foxglove_clients/package.json``, installed (exact versions)."""
    if os.environ.get("AIOGENOMIX_HEAVY") == "0":
        pytest.skip("heavy: run once, on the default Python")
    if shutil.which("npm") is None or shutil.which("node") is None:
        pytest.skip("needs node and npm (./run test installs them)")
    wanted = (TOOLS / "package.json").read_text()
    installed = NODE_HOME / ".installed"  # the package.json of the last install that ended well
    if not installed.exists() or installed.read_text() != wanted:
        shutil.rmtree(NODE_HOME, ignore_errors=True)
        NODE_HOME.mkdir(parents=True)
        (NODE_HOME / "package.json").write_text(wanted)
        done = subprocess.run(["npm", "install", "--no-package-lock", "--no-audit", "--no-fund", "--silent"],
                              cwd=NODE_HOME, capture_output=True, text=True, timeout=600, stdin=subprocess.DEVNULL,
                              check=False)
        assert done.returncode == 0, done.stderr[-3000:]
        installed.write_text(wanted)
    shutil.copy(TOOLS / "subscribe.js", NODE_HOME / "subscribe.js")
    return NODE_HOME


async def test_the_foxglove_ws_protocol_client_gets_the_head_a_camera_and_the_audio(
        gateway: tuple[str, int], foxglove_client: Path) -> None:  # noqa: F811
    """``FoxgloveClient`` 0.8.0 offers only ``foxglove.websocket.v1``: the SDK's own server refused it (400)."""
    _, port = gateway
    node = await asyncio.create_subprocess_exec(
        "node", str(foxglove_client / "subscribe.js"), f"ws://127.0.0.1:{port}/", *TOPICS,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE, stdin=asyncio.subprocess.DEVNULL)
    out, err = await asyncio.wait_for(node.communicate(), 120)
    assert node.returncode == 0, err.decode()[-3000:]
    lines = [json.loads(line) for line in out.decode().splitlines()]
    assert lines[0] == {"serverInfo": "aiogenomix", "protocol": "foxglove.websocket.v1"}
    channels = {line["topic"]: line for line in lines[1:]}
    assert set(channels) == set(TOPICS)
    schemas = {"/kemar/currentState": "foxglove.JointStates", "/world/kemar_camera_left": "foxglove.RawImage",
               "/kemarcapture/Port": "foxglove.RawAudio"}
    assert {t: c["schemaName"] for t, c in channels.items()} == schemas
    # Decoded here with the schemas the view advertises (as the client saw them, in the order of TOPICS).
    import websockets

    async with websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                                  max_size=None, close_timeout=1) as viewer:
        advertisement = await advertised(viewer, set(TOPICS))
    check_decoded({topic: decoder(advertisement[topic]).FromString(base64.b64decode(line["data"]))
                   for topic, line in channels.items()})
