"""The processes a benchmark talks to: the gateway (with a probe component) and the floors.

Run as ``python -m bench._server gateway|aiohttp|socket|socket_strict|zenoh|relay [options]``; each prints
``ready <port> [<port>]`` (``ready <endpoint>`` for Zenoh) once it listens, then serves until killed.
"""

from __future__ import annotations

import argparse
import asyncio
import socket
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
from aiohttp import web

from aiogenomix.components.core import (
    Component, ComponentHost, Double, OutPort, Out, ScaledClock, Task, activity, function, idl_struct,
)
from aiogenomix.gateway import GatewayConfig, serve

if TYPE_CHECKING:
    import zenoh  # only the Zenoh floor loads it: the gateway's memory is measured without


@idl_struct("probe::tick")
class Tick:
    """A publication stamped with the publisher's monotonic clock."""

    t: Double = 0.0


class Probe(Component, name="probe"):
    """Stamps replies and publications with time.monotonic(), for latency measurements."""

    ticking = Task(period=0.05, doc="Publishes a stamped tick, 20 times per second")
    Ticks = OutPort(Tick, doc="Stamped ticks")

    @ticking.periodic
    def _tick(self) -> None:
        self.Ticks.publish(Tick(time.monotonic()))

    @function
    def Stamp(self) -> Annotated[Double, Out("t", "time.monotonic() when the request ended")]:
        """Return the server's monotonic time."""
        return time.monotonic()

    @activity
    async def StampActivity(self) -> Annotated[Double, Out("t", "time.monotonic() when the activity ended")]:
        """An activity that ends at once, returning the server's monotonic time."""
        return time.monotonic()


def _config(**settings: Any) -> GatewayConfig:
    """A gateway's configuration from flat settings, whichever checkout is measured.

    Since decision 42 a configuration holds settings groups and is built by ``GatewayConfig.of``; a
    baseline checkout that predates it takes the same names as its own fields.
    """
    build: Callable[..., GatewayConfig] = getattr(GatewayConfig, "of", GatewayConfig)
    return build(**settings)


async def _gateway(args: argparse.Namespace) -> None:
    # Served as the gateway's command serves it (its HTTP layer included), with a probe component.
    # record_dirs only when asked: a baseline checkout's GatewayConfig may predate it.
    recording = {"record_dirs": args.record_dir} if args.record_dir else {}
    sessions = {"max_sessions": args.max_sessions} if args.max_sessions else {}
    config = _config(host="127.0.0.1", port=0, audio_socket_port=0, time_scale=1.0, **sessions, **recording)
    host = ComponentHost(clock=ScaledClock(1.0), settings=config.host_settings())
    host.register("probe", Probe)
    async with serve(config, host) as url:
        print("ready", url.rsplit(":", 1)[1], flush=True)
        await asyncio.Event().wait()


async def _bare_aiohttp(args: argparse.Namespace) -> None:
    small = b'{"id":"demo::0","status":"done","output":{"speedRef":"::demo::SLOW"}}'

    async def handler(request: web.Request) -> web.Response:
        return web.Response(body=small, content_type="application/json")

    app = web.Application()
    app.router.add_get("/{tail:.*}", handler)
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    await web.TCPSite(runner, "127.0.0.1", 0).start()
    print("ready", runner.addresses[0][1], flush=True)
    await asyncio.Event().wait()


async def _socket_floor(args: argparse.Namespace) -> None:
    """Answer each request line with a length-prefixed blob of the requested size (the byte floor)."""
    blobs: dict[int, bytes] = {}

    async def client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        while line := await reader.readline():
            size = int(line)
            if size not in blobs:
                blobs[size] = np.random.default_rng(0).integers(0, 256, size, dtype=np.uint8).tobytes()
            blob = blobs[size]
            writer.write(len(blob).to_bytes(4, "little"))
            writer.write(blob)
            await writer.drain()
        writer.close()

    server = await asyncio.start_server(client, "127.0.0.1", 0)
    print("ready", server.sockets[0].getsockname()[1], flush=True)
    await server.serve_forever()


async def _zenoh_floor(args: argparse.Namespace) -> None:
    """Answer each Zenoh query on ``bench/floor`` from the event loop, with nothing else to do.

    A component host hands each query to its loop the same way: this is the floor of a remote call.
    """
    # Here, not at the top: the gateway's memory is measured from this module without them.
    from aiogenomix.remote._session import ZenohSettings, on_zenoh_thread, open_session

    from ._common import free_port

    loop = asyncio.get_running_loop()
    listen = f"tcp/127.0.0.1:{free_port()}"
    session, _ = open_session(ZenohSettings(listen=(listen,)))

    def answer(query: zenoh.Query) -> None:
        query.reply(query.key_expr, b'{"ok":{"id":"demo::0","status":"done","output":{}}}', express=True)
        query.drop()

    def hand_over(query: zenoh.Query) -> None:
        loop.call_soon_threadsafe(answer, query)

    queryable = session.declare_queryable("bench/floor", on_zenoh_thread(hand_over))
    print("ready", listen, flush=True)
    try:
        await asyncio.Event().wait()
    finally:
        queryable.undeclare()
        session.close()


async def _zenoh_relay(args: argparse.Namespace) -> None:
    """A bare aiohttp server that forwards each request through one Zenoh query (to ``bench/floor``).

    With the Zenoh floor's process on the other end, it is the relay floor F of a remote call: the
    same three processes (HTTP client, a process that relays, a process that answers from its event
    loop) and nothing else: no genomix, no component, no bookkeeping.
    """
    import zenoh

    from aiogenomix.remote._session import ZenohSettings, on_zenoh_thread, open_session

    loop = asyncio.get_running_loop()
    session, _ = open_session(ZenohSettings(connect=(args.connect,)))

    def ask() -> asyncio.Future[bytes]:
        answer: asyncio.Future[bytes] = loop.create_future()

        def settle(body: bytes) -> None:
            if not answer.done():
                answer.set_result(body)

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                loop.call_soon_threadsafe(settle, reply.ok.payload.to_bytes())

        session.get("bench/floor", on_zenoh_thread(on_reply), payload=b'{"service":"GetSpeed"}', timeout=5.0,
                    express=True, consolidation=zenoh.ConsolidationMode.NONE)
        return answer

    async def handler(request: web.Request) -> web.Response:
        return web.Response(body=await ask(), content_type="application/json")

    while True:  # connected once a query is answered
        try:
            async with asyncio.timeout(1.0):
                await ask()
            break
        except TimeoutError:
            continue
    app = web.Application()
    app.router.add_get("/{tail:.*}", handler)
    runner = web.AppRunner(app, access_log=None)
    await runner.setup()
    await web.TCPSite(runner, "127.0.0.1", 0).start()
    print("ready", runner.addresses[0][1], flush=True)
    try:
        await asyncio.Event().wait()
    finally:
        session.close()


async def _strict_floor(args: argparse.Namespace) -> None:
    """The strict floor: each request line answered by one blocking ``sendall`` of a buffer made beforehand.

    No event loop and no copy on the way: a thread per connection reads a line and hands the
    kernel the length-prefixed blob of that size, made once per size.
    """
    blobs: dict[int, bytes] = {}
    made = threading.Lock()

    def serve(connection: socket.socket) -> None:
        with connection, connection.makefile("rb") as lines:
            for line in lines:
                size = int(line)
                with made:
                    if size not in blobs:
                        blob = np.random.default_rng(0).integers(0, 256, size, dtype=np.uint8).tobytes()
                        blobs[size] = len(blob).to_bytes(4, "little") + blob
                connection.sendall(blobs[size])

    listener = socket.create_server(("127.0.0.1", 0))
    print("ready", listener.getsockname()[1], flush=True)
    while True:
        connection, _ = await asyncio.to_thread(listener.accept)
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        threading.Thread(target=serve, args=(connection,), daemon=True).start()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("kind", choices=["gateway", "aiohttp", "socket", "socket_strict", "zenoh", "relay"])
    parser.add_argument("--profile", metavar="FILE", help="profile with cProfile; write the stats on SIGTERM")
    parser.add_argument("--max-sessions", type=int, default=None,
                        help="the gateway's cap on sessions (default: the gateway's own)")
    parser.add_argument("--connect", help="the relay's Zenoh endpoint to connect to (the Zenoh floor's)")
    parser.add_argument("--record-dir", action="append", default=[], help="a directory recordings may be made in")
    args = parser.parse_args()
    runner = {"gateway": _gateway, "aiohttp": _bare_aiohttp, "socket": _socket_floor, "socket_strict": _strict_floor,
              "zenoh": _zenoh_floor, "relay": _zenoh_relay}[args.kind]
    if not args.profile:
        asyncio.run(runner(args))
        return
    import cProfile
    import signal

    profiler = cProfile.Profile()

    def stop(*_: object) -> None:
        profiler.disable()
        profiler.dump_stats(args.profile)
        raise SystemExit(0)

    signal.signal(signal.SIGTERM, stop)
    profiler.enable()
    asyncio.run(runner(args))


if __name__ == "__main__":
    main()
