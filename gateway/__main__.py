"""Command line of the gateway: ``aiogenomix-gateway`` / ``python -m aiogenomix.gateway``."""

from __future__ import annotations

import argparse
import dataclasses
import errno
import logging
import sys
from typing import TYPE_CHECKING

from ..components.core.runtime import add_settings_arguments, installed_settings_groups, settings_from
from ._config import GatewayConfig
from ._signals import StopSignal, ignore_stop_signals, raise_on_stop_signals

if TYPE_CHECKING:
    from ._run import ListenError

__all__ = ["main", "parse_args"]


def parse_args(argv: list[str] | None = None) -> GatewayConfig:
    """Turn command-line arguments into a :class:`GatewayConfig`.

    The options are made from the settings groups the configuration holds, and from those other
    packages declare (``aiogenomix.settings`` entry points), each in its section of ``--help``.
    """
    parser = argparse.ArgumentParser(
        prog="aiogenomix-gateway",
        description="A genomix-compatible HTTP/JSON gateway hosting the Two!Ears components.",
    )
    try:
        extra = tuple(group() for group in installed_settings_groups())
    except TypeError as exc:  # a package installed here that is broken: say which, no traceback
        parser.error(str(exc))
    defaults = GatewayConfig.of(extra=extra)
    parser.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    add_settings_arguments(parser, defaults.groups())
    args = parser.parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    rig = settings_from(parser, args, defaults.rig, budgets=settings_from(parser, args, defaults.rig.budgets),
                        extra=tuple(settings_from(parser, args, group) for group in extra))
    given = {field.name: settings_from(parser, args, getattr(defaults, field.name))
             for field in dataclasses.fields(defaults) if field.name != "rig"}
    return dataclasses.replace(defaults, rig=rig, **given)


def main(argv: list[str] | None = None) -> int:
    """Run the gateway until SIGINT/SIGTERM; return the exit status.

    A stop signal stops it at any moment from its first line, with status 0.
    An address it cannot listen on is one line on stderr and status 1.
    """
    # Before the slow imports (aiohttp, the components), which take most of the start.
    raise_on_stop_signals()
    try:
        config = parse_args(argv)
        print("aiogenomix gateway starting", file=sys.stderr, flush=True)
        if any(arg == "--token" or arg.startswith("--token=") for arg in (sys.argv[1:] if argv is None else argv)):
            # Every user of the machine can read a process's command line (/proc/PID/cmdline).
            print("aiogenomix gateway: warning: a --token on the command line can be read by every user of this "
                  "machine (ps, /proc); set AIOGENOMIX_TOKEN in the environment instead", file=sys.stderr, flush=True)
        from ._run import ListenError, run

        refused = _refused_device(config.rig.audio_device)
        if refused:
            print(f"aiogenomix-gateway: error: argument --audio-device: {refused}", file=sys.stderr, flush=True)
            return 2
        zenoh_errors: tuple[type[Exception], ...] = ()
        if config.uses_zenoh:
            from ..remote import ZenohSessionError  # imports Zenoh: only when asked for

            zenoh_errors = (ZenohSessionError,)
        try:
            run(config)
        except ListenError as exc:
            print(f"aiogenomix gateway: {exc}; {_listen_hint(exc)}", file=sys.stderr, flush=True)
            return 1
        except zenoh_errors as exc:
            print(f"aiogenomix gateway: {exc}", file=sys.stderr, flush=True)
            return 1
    except StopSignal as stop:
        print(f"aiogenomix gateway stopping on {stop}", file=sys.stderr, flush=True)
    finally:
        ignore_stop_signals()
    print("aiogenomix gateway stopped", file=sys.stderr, flush=True)
    return 0


def _refused_device(device: str) -> str | None:
    """Why the capture device *device* names no backend (None: it names one).

    Checked once the components are imported (they are, by the gateway's start): the backends of
    other packages are known by then, and the flag is refused before anything listens.
    """
    from ..components.audio import UnknownDevicePrefix, split_device

    try:
        split_device(device)
    except UnknownDevicePrefix as exc:
        return str(exc)
    return None


def _listen_hint(exc: ListenError) -> str:
    """What to change on the command line when the HTTP address cannot be listened on."""
    if exc.errno == errno.EADDRINUSE:
        return f"another program (another gateway?) uses port {exc.port}: choose another with --port"
    if exc.errno == errno.EACCES:
        return "ports below 1024 need privileges: choose another with --port"
    if exc.errno == errno.EADDRNOTAVAIL or (exc.errno or 0) < 0:
        return f"{exc.host} is not an address of this machine: choose one with --host"
    return "check --host and --port"


if __name__ == "__main__":
    sys.exit(main())
