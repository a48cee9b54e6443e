"""Issue 33, item 3: a settings group declares each setting once; the command lines and the refusals follow.

The gateway's and a component host's options are made from the groups, with the same words and
defaults; a value is refused the same way from the command line (a usage error naming the flag)
and from code (a ``ValueError`` naming the field and the flag); ``GatewayConfig`` holds the groups.
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys

import pytest

from aiogenomix.components.core import Budgets, HostSettings, SettingsGroup, at_least, setting, whole_at_least
from aiogenomix.components.core.runtime import add_settings_arguments, declared_settings, settings_from
from aiogenomix.gateway import GatewayConfig
from aiogenomix.gateway.__main__ import parse_args


@dataclasses.dataclass(frozen=True)
class Lamp(SettingsGroup, section="lamp", about="a lamp on the rig"):
    """A group as another package declares one."""

    level: float = setting(0.5, flag="--lamp-level", refuse=at_least(0.0), help="brightness, 0 to 1")
    bulbs: int = setting(3, flag="--lamp-bulbs", metavar="N", refuse=whole_at_least(1), help="bulbs lit")
    rooms: tuple[str, ...] = setting((), flag="--lamp-room", metavar="ROOM", help="a room it lights (repeatable)")
    on: bool = setting(False, flag="--lamp-on", help="light it at start")
    colour: str = "white"


def parser_of(*groups: SettingsGroup) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="rig", exit_on_error=False)
    add_settings_arguments(parser, groups)
    return parser


def test_a_group_is_its_options_with_their_defaults_and_parsers() -> None:
    parser = parser_of(Lamp())
    shown = " ".join(parser.format_help().split())
    assert "lamp: a lamp on the rig --lamp-level LAMP_LEVEL brightness, 0 to 1 (default 0.5)" in shown
    assert "--lamp-bulbs N bulbs lit (default 3)" in shown and "--lamp-on light it at start" in shown
    args = parser.parse_args(["--lamp-level", "0.8", "--lamp-room", "lab", "--lamp-room", "hall", "--lamp-on"])
    assert settings_from(parser, args, Lamp()) == Lamp(level=0.8, bulbs=3, rooms=("lab", "hall"), on=True)
    # Not given: the defaults the options were made with, not the class's (a gateway's rig names no files).
    defaults = Lamp(bulbs=5, rooms=("lab",))
    parser = parser_of(defaults)
    assert settings_from(parser, parser.parse_args([]), defaults) == defaults
    # A field without a flag is the caller's.
    assert settings_from(parser, args, Lamp(), colour="red").colour == "red"
    assert [field.name for field, _ in declared_settings(Lamp)] == ["level", "bulbs", "rooms", "on"]


def test_a_refusal_reads_the_same_from_the_command_line_and_from_code(capsys: pytest.CaptureFixture[str]) -> None:
    parser = argparse.ArgumentParser(prog="rig")
    add_settings_arguments(parser, [Lamp()])
    with pytest.raises(SystemExit):
        parser.parse_args(["--lamp-bulbs", "0"])
    assert "rig: error: argument --lamp-bulbs: takes a whole number, 1 or more, not 0" in capsys.readouterr().err
    with pytest.raises(ValueError, match=r"^bulbs \(--lamp-bulbs\) takes a whole number, 1 or more, not 0$"):
        Lamp(bulbs=0)
    with pytest.raises(ValueError, match=r"level \(--lamp-level\) takes a number, 0 or more, not nan"):
        Lamp(level=float("nan"))
    given: list[str] = ["lab"]
    assert Lamp(rooms=given).rooms == ("lab",)   # type: ignore[arg-type]  # (a list kept as a tuple: frozen)


def test_the_budgets_and_the_rig_are_groups_declared_once() -> None:
    assert Budgets.flag("port_bytes") == "--max-port-bytes" and Budgets.unit("block_frames") == "frames"
    with pytest.raises(ValueError, match=r"port_bytes \(--max-port-bytes\) takes a whole number, 1 or more"):
        Budgets(port_bytes=0)
    with pytest.raises(ValueError, match=r"audio_socket_port \(--audio-socket-port\) takes a TCP port"):
        HostSettings(audio_socket_port=70000)
    with pytest.raises(ValueError, match=r"can_timeout \(--can-timeout\) takes a positive number"):
        HostSettings(can_timeout=0.0)


def test_the_gateway_configuration_holds_groups_not_copies() -> None:
    config = GatewayConfig()
    groups = [getattr(config, field.name) for field in dataclasses.fields(config)]
    assert all(isinstance(group, SettingsGroup) for group in groups)
    assert list(config.groups()) == [config.server, config.access, config.rig, config.rig.budgets, config.clock,
                                     config.connections, config.sessions, config.remote, config.zenoh,
                                     config.remote_timeouts, config.view]
    built = GatewayConfig.of(port=0, token="s3cret", max_sessions=3, connect=["tcp/robot:7447"], budgets=Budgets(
        recordings=1))
    assert (built.server.port, built.access.token, built.sessions.max_sessions) == (0, "s3cret", 3)
    assert built.zenoh.connect == ("tcp/robot:7447",) and built.uses_zenoh and built.rig.budgets.recordings == 1
    with pytest.raises(TypeError, match="no settings group of the gateway has 'max_session'"):
        GatewayConfig.of(max_session=3)
    with pytest.raises(ValueError, match=r"max_viewers \(--max-viewers\) takes a whole number, 1 or more"):
        GatewayConfig.of(max_viewers=0)
    # What the components are told: the rig, with the socket on the gateway's address and its token.
    settings = built.host_settings()
    assert (settings.audio_socket_host, settings.audio_socket_token) == ("127.0.0.1", "s3cret")


def test_every_flag_of_the_gateway_keeps_its_name_and_default() -> None:
    config = parse_args(["--zenoh-connect", "tcp/robot:7447", "--zenoh-timeout", "1.5", "--local", "kemar",
                         "--max-viewer-bytes", "8M", "--record-mode", "640", "--components", "demo,kemar"])
    assert config.zenoh.connect == ("tcp/robot:7447",) and config.uses_zenoh and config.remote.local == ("kemar",)
    assert config.remote_timeouts.control == 1.5 and config.view.viewer_bytes == 8 << 20
    assert config.rig.record_mode == 0o640 and config.server.components == ("demo", "kemar")
    assert parse_args([]) == GatewayConfig() and not GatewayConfig().uses_zenoh


def test_the_component_host_takes_the_same_flags_with_the_same_words() -> None:
    def options(module: str) -> dict[str, str]:
        shown = subprocess.run([sys.executable, "-m", module, "--help"], capture_output=True, text=True, timeout=120,
                               env={"COLUMNS": "400", "PATH": ""})
        assert shown.returncode == 0, shown.stderr
        return {line.split()[0]: " ".join(line.split()) for line in shown.stdout.splitlines()
                if line.startswith("  --")}

    gateway, host = options("aiogenomix.gateway"), options("aiogenomix.remote._host_main")
    shared = ["--zenoh-connect", "--zenoh-listen", "--zenoh-config", "--zenoh-scout", "--can", "--can-timeout",
              "--audio-device", "--audio-files", "--record-dir", "--record-mode", "--audio-socket-port",
              "--time-scale", "--max-port-bytes", "--max-recordings", "--max-recording-seconds"]
    for flag in shared:
        assert gateway[flag] == host[flag], flag


def test_the_configuration_holds_zenohs_settings_without_importing_zenoh() -> None:
    # A gateway that asks for no remote component never loads Zenoh (a robot without it still serves).
    code = ("import sys\nfrom aiogenomix.gateway.__main__ import parse_args\n"
            "config = parse_args(['--zenoh-timeout', '3'])\n"
            "print(config.remote_timeouts.control, config.uses_zenoh, 'zenoh' in sys.modules)\n"
            "from aiogenomix.remote import ZenohDirectory\nprint('zenoh' in sys.modules)")
    shown = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert shown.stdout.split() == ["3.0", "False", "False", "True"], shown.stderr
