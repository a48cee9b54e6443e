"""Command line of the gateway: ``aiogenomix-gateway`` / ``python -m aiogenomix.gateway``."""

from __future__ import annotations

import argparse
import errno
import logging
import os
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..components.core.runtime import add_budget_arguments, add_rig_arguments, budgets_from, parse_amount
from ._config import GatewayConfig
from ._signals import StopSignal, ignore_stop_signals, raise_on_stop_signals

if TYPE_CHECKING:
    from ._run import ListenError

__all__ = ["main", "parse_args"]


def parse_args(argv: list[str] | None = None) -> GatewayConfig:
    """Turn command-line arguments into a :class:`GatewayConfig`."""
    defaults = GatewayConfig()
    parser = argparse.ArgumentParser(
        prog="aiogenomix-gateway",
        description="A genomix-compatible HTTP/JSON gateway hosting the Two!Ears components.",
    )
    parser.add_argument("--host", default=defaults.host, help="address to bind (default %(default)s)")
    parser.add_argument("--port", type=int, default=defaults.port,
                        help="HTTP port, 0 for a free one (default %(default)s)")
    add_rig_arguments(parser)
    parser.add_argument("--load", action="append", default=[], metavar="NAME[:ARGS]",
                        help="load a component at start (repeatable), e.g. demo, or 'demo:-i demo2' (quoted: it holds "
                             "a space)")
    parser.add_argument("--components", help="comma-separated allow-list of loadable components")
    parser.add_argument("--token", default=os.environ.get("AIOGENOMIX_TOKEN"),
                        help="require 'Authorization: Bearer TOKEN'; better given as $AIOGENOMIX_TOKEN, which "
                             "other users cannot read in the process list (unset: open)")
    parser.add_argument("--allowed-host", action="append", default=[], metavar="NAME",
                        help="a host name browsers may reach the gateway by, besides IP addresses, localhost and "
                             "this machine's names (repeatable; '*' for any)")
    parser.add_argument("--allow-origin", action="append", default=[], metavar="ORIGIN",
                        help="a web origin (scheme://host:port) whose pages may use the gateway (repeatable)")
    remote = parser.add_argument_group(
        "remote components", "components that run in other processes or on other hosts (aiogenomix-component), "
                              "found on Zenoh; the gateway talks to nobody but the endpoints given")
    remote.add_argument("--zenoh", action="store_true",
                        help="load components offered on Zenoh (implied by the options below): every name then runs "
                             "where a host offers it, never in this gateway unless named with --local")
    remote.add_argument("--zenoh-connect", action="append", default=[], metavar="ENDPOINT",
                        help="a Zenoh endpoint to connect to, e.g. tcp/192.168.1.10:7447 (repeatable)")
    remote.add_argument("--zenoh-listen", action="append", default=[], metavar="ENDPOINT",
                        help="a Zenoh endpoint to listen on, for hosts that connect to the gateway (repeatable; "
                             "none by default)")
    remote.add_argument("--zenoh-config", default=None, metavar="FILE",
                        help="Zenoh's own configuration file (JSON5): TLS, user/password, access control, a "
                             "router; --zenoh-connect and --zenoh-listen replace its endpoints")
    remote.add_argument("--zenoh-scout", action="store_true",
                        help="find hosts by multicast scouting and gossip and listen on every interface (Zenoh's "
                             "defaults): only on a network where every machine is trusted")
    remote.add_argument("--local", action="append", default=[], metavar="NAME",
                        help="a component that runs in this gateway even with remote components (repeatable); "
                             "any other name runs only where a component host offers it")
    remote.add_argument("--zenoh-timeout", type=_at_least(float, 0.1), default=defaults.zenoh_timeout,
                        metavar="SECONDS", help="time a component host has to answer, or to offer again a name it "
                                                "offered, before the gateway answers ::genom::remote_io "
                                                "(default %(default)s)")
    remote.add_argument("--zenoh-stale", type=_at_least(float, 0.5), default=defaults.zenoh_stale,
                        metavar="SECONDS", help="time without news of a component host after which reads of its "
                                                "ports answer ::genom::remote_io rather than old data "
                                                "(default %(default)s)")
    view = parser.add_argument_group(
        "live view", "the robot's head, cameras, odometry, laser and audio in Foxglove or Lichtblick (the Foxglove "
                     "WebSocket protocol; pip install aiogenomix[foxglove])")
    view.add_argument("--foxglove", type=int, metavar="PORT", dest="foxglove_port",
                      help="serve the live view on this port (0 for a free one; default: no view); it admits viewers "
                           "as the gateway admits requests (--token as ws://HOST:PORT/?token=..., --allow-origin, "
                           "--allowed-host)")
    view.add_argument("--foxglove-host", default=defaults.foxglove_host, metavar="ADDRESS",
                      help="address of the live view (default %(default)s: this machine only)")
    view.add_argument("--max-viewers", type=_at_least(int, 1), default=defaults.max_viewers, metavar="N",
                      help="most viewers connected at once, else 429 (default %(default)s)")
    view.add_argument("--max-viewer-bytes", type=parse_amount, default=defaults.viewer_bytes, metavar="BYTES",
                      help="bytes one viewer may hold unsent (it does not read, or falls ever further behind) before "
                           f"it is dropped (default {defaults.viewer_bytes // 2**20}M)")
    limits = parser.add_argument_group("limits", "what one client can hold or send")
    limits.add_argument("--header-timeout", type=_at_least(float, 0.001), default=defaults.header_timeout,
                        metavar="SECONDS", help="time a client has to send a request's line and headers, "
                                                "else 408 (default %(default)s)")
    limits.add_argument("--max-url-bytes", type=_at_least(int, 8192), default=defaults.max_url_bytes, metavar="N",
                        help="longest request line (URL with input=), else 414 (default %(default)s)")
    limits.add_argument("--session-idle", type=_at_least(float, 0.001), default=defaults.session_idle,
                        metavar="SECONDS", help="a session nobody listens to is forgotten after this long unused "
                                                "(default %(default)s)")
    limits.add_argument("--max-sessions", type=_at_least(int, 1), default=defaults.max_sessions, metavar="N",
                        help="most sessions at once, else 429 (default %(default)s)")
    limits.add_argument("--max-instances", type=_at_least(int, 1), default=defaults.max_instances, metavar="N",
                        help="most component instances loaded at once, else 429 (default %(default)s)")
    add_budget_arguments(limits, defaults.budgets)
    args = parser.parse_args(argv)
    budgets = budgets_from(parser, args)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    config = GatewayConfig(
        host=args.host, port=args.port, time_scale=args.time_scale, can=args.can, can_timeout=args.can_timeout,
        audio_device=args.audio_device, audio_socket_port=args.audio_socket_port, audio_files=args.audio_files,
        record_dirs=args.record_dir, record_mode=args.record_mode,
        token=args.token or None, allowed_hosts=args.allowed_host, allowed_origins=args.allow_origin,
        components=args.components.split(",") if args.components else None, preload=args.load,
        header_timeout=args.header_timeout, max_url_bytes=args.max_url_bytes, session_idle=args.session_idle,
        max_sessions=args.max_sessions, max_instances=args.max_instances, budgets=budgets,
        zenoh=bool(args.zenoh or args.zenoh_connect or args.zenoh_listen or args.zenoh_config or args.zenoh_scout),
        zenoh_connect=args.zenoh_connect, zenoh_listen=args.zenoh_listen, zenoh_config=args.zenoh_config,
        zenoh_scout=args.zenoh_scout, zenoh_local=args.local, zenoh_timeout=args.zenoh_timeout,
        zenoh_stale=args.zenoh_stale, foxglove_port=args.foxglove_port, foxglove_host=args.foxglove_host,
        max_viewers=args.max_viewers, viewer_bytes=args.max_viewer_bytes,
    )
    try:
        config.check()
    except ValueError as exc:
        parser.error(str(exc))
    return config


def _at_least(kind: type[float] | type[int], low: float) -> Callable[[str], float]:
    """An argparse type: a number of *kind*, *low* or more."""

    def parse(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not value >= low:  # NaN too
            raise argparse.ArgumentTypeError(f"{text} is less than {low:g}")
        return value

    return parse


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

        zenoh_errors: tuple[type[Exception], ...] = ()
        if config.zenoh:
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
