"""Issue 33: a package of another author brings a component, its settings flag, its port kind and a capture backend.

``outside_package/`` is that package: its ``pyproject.toml`` declares the four entry points
(``aiogenomix.components``, ``aiogenomix.settings``, ``aiogenomix.capture_backends``,
``aiogenomix.port_kinds``).  It is installed here as an installer lays a package out (its module
beside a ``.dist-info`` directory holding its metadata and entry points) in a directory of its own,
on the path of the processes the tests start: the gateway's command line, ``--help``, the
component's settings, the capture's device prefixes and a fresh process's port kinds all come
from the entry points, over real sockets.  The package type-checks under ``mypy --strict`` and
pyright with no ``type: ignore``.
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import subprocess
import sys
import tomllib
from collections.abc import AsyncIterator
from pathlib import Path

import aiohttp
import numpy as np
import pytest

from aiogenomix.clients import RemoteError, aconnect

from ..remote._processes import Process

HERE = Path(__file__).parent
PACKAGE = HERE / "outside_package"
GAIN = -6.0


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The outside package installed in a directory of its own: its module and its dist-info (entry points)."""
    site = tmp_path_factory.mktemp("site")
    shutil.copytree(PACKAGE / "outside_ears", site / "outside_ears", ignore=shutil.ignore_patterns("__pycache__"))
    project = tomllib.loads((PACKAGE / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    info = site / f"outside_ears-{project['version']}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    groups = [f"[{group}]\n" + "".join(f"{name} = {value}\n" for name, value in entries.items())
              for group, entries in project["entry-points"].items()]
    (info / "entry_points.txt").write_text("\n".join(groups), encoding="utf-8")
    return site


def environment(site: Path) -> dict[str, str]:
    """The environment of a process on whose path the outside package is installed."""
    env = {name: value for name, value in os.environ.items() if name != "AIOGENOMIX_TOKEN"}
    env["PYTHONPATH"] = os.pathsep.join([str(site), *filter(None, [os.environ.get("PYTHONPATH")])])
    return env


def gateway_command(site: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "aiogenomix.gateway", *args], env=environment(site),
                          capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)


def test_the_outside_flag_is_in_the_help_and_refused_as_the_package_says(site: Path) -> None:
    shown = gateway_command(site, "--help")
    assert shown.returncode == 0, shown.stderr
    section = shown.stdout.split("\nears:\n", 1)[1]
    assert section.startswith("  the ears of the outside-ears package\n"), shown.stdout
    assert " ".join(section.split()).startswith("the ears of the outside-ears package --ears-gain DB gain the ears "
                                                "apply to what they hear, in dB (default 0.0)")
    # Every flag of ours is still there, in its place.
    for flag in ("--port PORT", "--audio-device DEVICE", "--max-port-bytes BYTES", "--zenoh-connect ENDPOINT",
                 "--foxglove PORT", "--header-timeout SECONDS", "--token TOKEN"):
        assert flag in shown.stdout
    refused = gateway_command(site, "--port", "0", "--ears-gain", "50")
    assert refused.returncode == 2 and "" == refused.stdout
    assert "argument --ears-gain: takes a gain from -60 to 20 dB, not 50" in refused.stderr


def test_an_unknown_device_prefix_on_the_command_line_is_refused_naming_the_known_ones(site: Path) -> None:
    refused = gateway_command(site, "--port", "0", "--audio-socket-port", "0", "--audio-device", "tonne:440")
    assert refused.returncode == 2
    message = refused.stderr.strip().splitlines()[-1]
    assert message.startswith("aiogenomix-gateway: error: argument --audio-device: no capture backend has the "
                              "device prefix 'tonne' (in 'tonne:440')"), message
    assert all(prefix in message for prefix in ("sim", "file", "mcap", "pa", "alsa", "tone")), message
    assert "Traceback" not in refused.stderr


@pytest.fixture
async def gateway(site: Path) -> AsyncIterator[str]:
    """A gateway with the outside package installed and ``--ears-gain -6``: its URL."""
    process = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "aiogenomix.gateway", "--port", "0", "--audio-socket-port", "0", "--time-scale", "10",
        "--ears-gain", str(GAIN), "--load", "ears", "--load", "capture", env=environment(site),
        stdin=asyncio.subprocess.DEVNULL, stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE)
    gateway = Process(process, "gateway")
    try:
        url = (await gateway.line_matching(r"listening on (http://\S+)", stream="stdout", timeout=120)).group(1)
        gateway.drain()
        yield url
    finally:
        await gateway.end()
    assert gateway.process.returncode == 0


def frequency_and_peak(samples: np.ndarray, rate: int) -> tuple[float, float]:
    """The strongest frequency of the left channel of interleaved *samples*, and its peak."""
    left = samples[0::2].astype(np.float64)
    spectrum = np.abs(np.fft.rfft(left * np.hanning(len(left))))
    return float(np.argmax(spectrum) * rate / len(left)), float(np.max(np.abs(left)))


async def test_the_outside_component_takes_its_flag_and_its_backend_through_the_gateway(
        gateway: str, site: Path) -> None:
    async with aconnect(gateway) as rig:
        ears, capture = await rig.load("ears"), await rig.load("capture")
        assert await ears.Gain() == GAIN   # the flag's value reached the component
        await ears.Listen(device="tone:1000", seconds=0.5)
        block = await ears.Ears()
        frequency, peak = frequency_and_peak(np.asarray(block["samples"]), block["rate"])
        assert abs(frequency - 1000) < 10
        assert abs(peak - 2**14 * 10 ** (GAIN / 20)) < 3   # half scale, 6 dB down
        # Our own capture opens the outside backend by its prefix.
        await capture.StartCapture(device="tone:500", Port_chunks=10, ack=True)
        port = await capture.Port()
        while port["index"] < 10:
            port = await capture.Port()
        await capture.StopCapture()
        frames = np.asarray(port["left"], dtype=np.float64)
        assert abs(np.argmax(np.abs(np.fft.rfft(frames))) * 44100 / len(frames) - 500) < 5

        # An unknown prefix is the request's error, naming the known ones; the gateway goes on.
        with pytest.raises(RemoteError) as listening:
            await ears.Listen(device="tonne:1000", seconds=0.5)
        assert listening.value.ex == "::ears::EARS_DEVICE"
        assert "device prefix 'tonne'" in listening.value.detail["what"] and "tone" in listening.value.detail["what"]
        with pytest.raises(RemoteError) as capturing:
            await capture.StartCapture(device="tonne:500")
        assert capturing.value.ex == "::capture::DEVICE_ERROR" and "tone, " in str(capturing.value.detail)
        assert await ears.Gain() == GAIN

    async with aiohttp.ClientSession() as http, http.get(f"{gateway}/module/ears/info") as reply:
        described = await reply.json()
    loudness = next(p for p in described["ports"] if p["name"] == "Loudness")["type"]
    assert loudness["carries"] == {"kind": "ears_loudness", "level": "level"}
    # A process that never imported the package (an export of a recording) finds the kind by its entry point.
    found = subprocess.run(
        [sys.executable, "-c", "import json, sys\nfrom aiogenomix.components.core import carried_by\n"
         "kind = carried_by(json.loads(sys.argv[1]))\nprint(type(kind).__module__, type(kind).__name__, kind.level)",
         json.dumps(loudness)], env=environment(site), capture_output=True, text=True, timeout=120)
    assert found.stdout.split() == ["outside_ears._ears", "Loudness", "level"], found.stderr


@pytest.mark.skipif(os.environ.get("AIOGENOMIX_HEAVY") == "0", reason="heavy: run once, on the default Python")
def test_the_outside_package_type_checks_strictly_with_no_ignores(site: Path) -> None:
    sources = sorted((PACKAGE / "outside_ears").glob("*.py"))
    assert len(sources) >= 3 and not [s for s in sources if "type: ignore" in s.read_text(encoding="utf-8")]
    # From the package's own directory: no configuration of ours, the installed aiogenomix.
    mypy = subprocess.run([sys.executable, "-m", "mypy", "--strict", "--no-incremental", "-p", "outside_ears"],
                          cwd=site, capture_output=True, text=True, timeout=600)
    assert mypy.returncode == 0 and "Success: no issues found" in mypy.stdout, mypy.stdout


def test_pyright_finds_no_error_in_the_outside_package(site: Path, pyright_tool: Path) -> None:
    checked = subprocess.run([str(pyright_tool), "--pythonpath", sys.executable, "outside_ears"], cwd=site,
                             capture_output=True, text=True, timeout=600)
    assert checked.returncode == 0 and "0 errors" in checked.stdout, checked.stdout


def test_a_broken_settings_entry_point_is_named_without_a_traceback(site: Path, tmp_path: Path) -> None:
    broken = tmp_path / "broken-1.0.dist-info"
    broken.mkdir()
    (broken / "METADATA").write_text("Metadata-Version: 2.1\nName: broken\nVersion: 1.0\n")
    (broken / "entry_points.txt").write_text("[aiogenomix.settings]\nlamp = outside_ears:NoSuchGroup\n")
    env = environment(site)
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env["PYTHONPATH"]])
    refused = subprocess.run([sys.executable, "-m", "aiogenomix.gateway", "--port", "0"], env=env,
                             capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr, refused.stderr
    assert ("aiogenomix-gateway: error: the aiogenomix.settings entry point lamp (outside_ears:NoSuchGroup) cannot "
            "be loaded") in refused.stderr
