"""``aiogenomix-component``: run components in this process and offer them on Zenoh to gateways elsewhere.

::

    aiogenomix-component kemar capture --zenoh-listen tcp/0.0.0.0:7447
    aiogenomix-gateway --zenoh-connect tcp/ROBOT:7447        # then /load/kemar finds it

The simulated hardware stays with its component: a ``kemar`` host owns its virtual CAN bus and
simulated drive, as the gateway does when it hosts ``kemar`` itself.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
import sys

from ...components.core import ComponentHost, ScaledClock
from ...components.core.runtime import ComponentError
from .._config import GatewayConfig
from .._errors import ZenohSessionError
from .._rig_arguments import add_rig_arguments

__all__ = ["main", "parse_args"]

log = logging.getLogger(__name__)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line of ``aiogenomix-component``."""
    defaults = GatewayConfig()
    parser = argparse.ArgumentParser(
        prog="aiogenomix-component",
        description="Run components in this process and offer them on Zenoh to aiogenomix gateways "
                    "(started with --zenoh).",
    )
    parser.add_argument("names", nargs="+", metavar="NAME[:ARGS]",
                        help="a component to run, with its load options after a colon (e.g. demo, demo:-i demo2)")
    parser.add_argument("--zenoh-connect", action="append", default=[], metavar="ENDPOINT",
                        help="a Zenoh endpoint to connect to, e.g. tcp/192.168.1.2:7447 (repeatable)")
    parser.add_argument("--zenoh-listen", action="append", default=[], metavar="ENDPOINT",
                        help="a Zenoh endpoint to listen on, e.g. tcp/0.0.0.0:7447 (repeatable); with any "
                             "endpoint given, multicast scouting is off")
    add_rig_arguments(parser, defaults)
    parser.add_argument("--audio-socket-host", default=defaults.host,
                        help="address of the dedicated audio socket (default %(default)s)")
    parser.add_argument("--token", default=None,
                        help="token of the dedicated audio socket (the gateway checks its own HTTP token)")
    return parser.parse_args(argv)


async def serve(args: argparse.Namespace, stop: asyncio.Event) -> None:
    """Load the components, offer them until *stop* is set (or every one was killed), then withdraw them."""
    from ._directory import ZenohDirectory
    from ._exporter import ComponentExporter
    from ._session import ZenohEndpoints

    config = GatewayConfig(can=args.can, can_timeout=args.can_timeout, audio_device=args.audio_device,
                           audio_socket_port=args.audio_socket_port,
                           host=args.audio_socket_host, audio_files=args.audio_files, record_dirs=args.record_dir,
                           token=args.token)
    host = ComponentHost(clock=ScaledClock(args.time_scale), settings=config.host_settings())
    loop = asyncio.get_running_loop()
    exporters: dict[str, ComponentExporter] = {}
    closing: set[asyncio.Task[None]] = set()
    try:
        # Loaded before the directory is the host's finder: these run here, whoever else offers a name.
        for item in args.names:
            name, _, options = item.partition(":")
            await host.load(name, options.split())
        directory = await ZenohDirectory.open(ZenohEndpoints(connect=args.zenoh_connect, listen=args.zenoh_listen))
        host.shared("zenoh", lambda: directory)
        # connect_port of a component here may name an out port of another process.
        host.finder = directory

        def withdraw(instance: str) -> None:
            exporter = exporters.pop(instance, None)
            if exporter is not None:
                task = loop.create_task(exporter.close())
                closing.add(task)
                task.add_done_callback(closing.discard)
            if not exporters:
                stop.set()  # every component was killed: nothing left to offer

        host.add_unload_listener(withdraw)
        for instance, component in host.instances.items():
            exporters[instance] = ComponentExporter(directory.session, component, loop)
        print(f"aiogenomix-component: offering {', '.join(exporters)} on Zenoh", file=sys.stderr, flush=True)
        await stop.wait()
    finally:
        for exporter in list(exporters.values()):
            await exporter.close()
        exporters.clear()
        await asyncio.gather(*closing, return_exceptions=True)
        await host.close()


def main(argv: list[str] | None = None) -> int:
    """Run until SIGINT/SIGTERM; return the exit status (1 for a component that cannot be loaded)."""
    args = parse_args(argv)
    logging.basicConfig(level=args.log_level.upper(), format="%(asctime)s %(levelname)s %(name)s: %(message)s")

    async def run() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for signum in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(signum, stop.set)
        await serve(args, stop)

    try:
        asyncio.run(run())
    except (ComponentError, ZenohSessionError) as exc:
        print(f"aiogenomix-component: {exc}", file=sys.stderr, flush=True)
        return 1
    print("aiogenomix-component stopped", file=sys.stderr, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
