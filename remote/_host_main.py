"""``aiogenomix-component``: run components in this process and offer them on Zenoh to gateways elsewhere.

::

    aiogenomix-component kemar capture --host-id robot1 --zenoh-listen tcp/192.168.1.10:7447
    aiogenomix-gateway --zenoh-connect tcp/192.168.1.10:7447        # then /load/kemar finds it

The simulated hardware stays with its component: a ``kemar`` host owns its virtual CAN bus and
simulated drive, as the gateway does when it hosts ``kemar`` itself.  This process imports no module
of the HTTP gateway (an import-linter contract says so): a robot runs its components, not a web server.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import signal
import socket
import sys

from ..components.core import ClockSettings, Component, ComponentHost, HostSettings, ScaledClock
from ..components.core.runtime import (
    ComponentError, add_settings_arguments, installed_settings_groups, settings_from,
)
from ._session import ZenohSessionError
from ._settings import ZenohSettings
from ._wire import host_id_error

__all__ = ["main", "parse_args", "token_warning"]

log = logging.getLogger(__name__)

_EPILOG = """\
A component's load options follow its name after a colon, quoted when they hold a space:
'demo:-i demo2' runs a second demo as the instance demo2.

Gateways load an instance by its name (demo), or as NAME@HOST-ID (demo@robot1) when several hosts
offer the name.  Zenoh's own configuration file (--zenoh-config) gives TLS, user/password
authentication and access control; see the README's section on remote components.
"""


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line of ``aiogenomix-component``.

    Its options are made from the settings groups (Zenoh's, the rig's, its clock's, the budgets, and
    those of other packages' ``aiogenomix.settings`` entry points); the namespace holds them as
    ``zenoh``, ``rig`` (the budgets and other groups within) and ``clock``.
    """
    parser = argparse.ArgumentParser(
        prog="aiogenomix-component", epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Run components in this process and offer them on Zenoh to aiogenomix gateways "
                    "(started with --zenoh-connect or --zenoh-listen).",
    )
    parser.add_argument("names", nargs="+", metavar="NAME[:ARGS]",
                        help="a component to run, with its load options after a colon (e.g. demo, 'demo:-i demo2')")
    parser.add_argument("--host-id", default=None, metavar="NAME",
                        help="the name gateways know this host by, as in demo@NAME (default: this machine's name)")
    parser.add_argument("--log-level", default="info", choices=["debug", "info", "warning", "error"])
    try:
        extra = tuple(group() for group in installed_settings_groups())
    except TypeError as exc:  # a package installed here that is broken: say which, no traceback
        parser.error(str(exc))
    # The rig's files are the operator's choice here too: none unless named.
    rig, zenoh = HostSettings(audio_files=(), record_dirs=(), extra=extra), ZenohSettings()
    add_settings_arguments(parser, [zenoh, rig, ClockSettings(), rig.budgets, *extra])
    parser.add_argument("--audio-socket-host", default="127.0.0.1", metavar="ADDRESS",
                        help="address the dedicated audio sockets listen on (default %(default)s: only this machine "
                             "can connect; give an address of this machine to reach them from the gateway's)")
    parser.add_argument("--token", default=os.environ.get("AIOGENOMIX_TOKEN"),
                        help="token of the dedicated audio sockets (the gateway checks its own HTTP token); better "
                             "given as $AIOGENOMIX_TOKEN, which other users cannot read in the process list")
    args = parser.parse_args(argv)
    args.zenoh = settings_from(parser, args, zenoh)
    args.clock = settings_from(parser, args, ClockSettings())
    args.rig = settings_from(parser, args, rig, budgets=settings_from(parser, args, rig.budgets),
                             audio_socket_host=args.audio_socket_host, audio_socket_token=args.token or None,
                             extra=tuple(settings_from(parser, args, group) for group in extra)).for_operator()
    if args.host_id is None:
        args.host_id = socket.gethostname().split(".", 1)[0]
    problem = host_id_error(args.host_id)
    if problem:
        parser.error(f"{problem} (--host-id)")
    return args


def _say(line: str) -> None:
    print(f"aiogenomix-component: {line}", file=sys.stderr, flush=True)


def token_warning(argv: list[str]) -> str | None:
    """The start-up warning for a token on the command line *argv* (None: there is none)."""
    if any(arg == "--token" or arg.startswith("--token=") for arg in argv):
        # Every user of the machine can read a process's command line (/proc/PID/cmdline).
        return ("warning: a --token on the command line can be read by every user of this machine (ps, /proc); "
                "set AIOGENOMIX_TOKEN in the environment instead")
    return None


async def serve(args: argparse.Namespace, stop: asyncio.Event) -> None:
    """Load the components, offer them until *stop* is set (or every one was killed), then withdraw them."""
    from ._directory import ZenohDirectory
    from ._host_node import HostNode
    from ._session import connect_endpoints, listen_endpoints

    zenoh_settings: ZenohSettings = args.zenoh
    zenoh_settings.config()  # refused now, before any hardware is opened, when it cannot work
    settings: HostSettings = args.rig
    host = ComponentHost(clock=ScaledClock(args.clock.time_scale), settings=settings)
    node: HostNode | None = None
    closing: set[asyncio.Task[None]] = set()
    try:
        # Loaded before the directory is the host's finder: these run here, whoever else offers a name.
        for item in args.names:
            name, _, options = item.partition(":")
            await host.load(name, options.split())
        components = [c for c in host.instances.values() if isinstance(c, Component)]
        # This process is no gateway: it sends no request.  Its finder serves connect_port to an out port
        # of another process; what runs here was loaded above.
        directory = await ZenohDirectory.open(zenoh_settings, gateway=False)
        host.shared("zenoh", lambda: directory)
        # connect_port of a component here may name an out port of another process.
        host.finder = directory
        # Where gateways reach this host: where it listens, else whom it connects to (a router, a gateway).
        endpoints = listen_endpoints(directory.config) or connect_endpoints(directory.config)
        node = HostNode(directory.session, host, args.host_id, endpoints)

        def withdraw(instance: str) -> None:
            exporter = None if node is None else node.withdraw(instance)
            if exporter is None:
                return
            task = asyncio.get_running_loop().create_task(exporter.close(), name=f"withdraw {instance}")
            closing.add(task)
            task.add_done_callback(closing.discard)
            if node is not None and not node.exporters:
                stop.set()  # every component was killed: nothing left to offer

        host.add_unload_listener(withdraw)
        for component in components:
            node.offer(component)
        _say(f"host {args.host_id}, Zenoh session {node.zid}: {zenoh_settings.summary(directory.config)}")
        with_sockets = [c.instance for c in components if "DedicatedSocket" in type(c).services()]
        if with_sockets:
            where = f"{settings.audio_socket_host}:{settings.audio_socket_port or 'a free port'}"
            reach = ("only this machine can connect: give --audio-socket-host ADDRESS (an address of this machine) "
                     "for clients elsewhere" if settings.audio_socket_host in ("127.0.0.1", "localhost", "::1")
                     else "clients connect there")
            _say(f"dedicated audio sockets of {', '.join(with_sockets)} listen on {where} once opened "
                 f"(DedicatedSocket): {reach}")
        _say(f"offering {', '.join(node.exporters)} on Zenoh")
        await stop.wait()
    finally:
        if node is not None:
            await node.close()
        await asyncio.gather(*closing, return_exceptions=True)
        await host.close()


def main(argv: list[str] | None = None) -> int:
    """Run until SIGINT/SIGTERM; return the exit status (1 for a component that cannot be loaded)."""
    args = parse_args(argv)
    warning = token_warning(sys.argv[1:] if argv is None else argv)
    if warning:
        _say(warning)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    from ..components.audio import UnknownDevicePrefix, split_device

    try:
        split_device(args.rig.audio_device)  # refused before any component opens its hardware
    except UnknownDevicePrefix as exc:
        print(f"aiogenomix-component: error: argument --audio-device: {exc}", file=sys.stderr, flush=True)
        return 2

    async def run() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for signum in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(signum, stop.set)
        await serve(args, stop)

    try:
        asyncio.run(run())
    except (ComponentError, ZenohSessionError) as exc:
        _say(str(exc))
        return 1
    print("aiogenomix-component stopped", file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
