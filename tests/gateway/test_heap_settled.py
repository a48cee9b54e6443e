"""The gateway keeps what it holds for good out of the garbage collector's full passes, and still frees what it unloads.

A full pass of CPython's collector traverses every tracked object and runs on the event loop: over 100,000
objects once numpy, scipy and MuJoCo are imported, and the loop stood still for 16-56 ms. The gateway sets
them aside once it has started and after each load; an unload gives them back for one pass, so that an
unloaded instance's cycles are freed (components/core/_heap.py).
"""

from __future__ import annotations

import gc
import weakref

from aiogenomix.components.core import ComponentHost, ScaledClock
from aiogenomix.gateway import GatewayConfig, serve


def _config() -> GatewayConfig:
    return GatewayConfig.of(port=0, audio_socket_port=0)


async def test_a_started_gateway_leaves_the_collectors_full_passes_little_to_traverse() -> None:
    gc.unfreeze()      # whatever another test set aside: what follows is this gateway's doing
    before = len(gc.get_objects())
    async with ComponentHost(clock=ScaledClock(1)) as host:
        await host.load("demo")
        async with serve(_config(), host=host):
            traversed = len(gc.get_objects())
            assert gc.get_freeze_count() > before / 2
            assert traversed < before / 10, (traversed, before)
            # What came since (here a stand-in for the modules a component's first load imports) is set
            # aside by the next load.
            kept = [[index] for index in range(before)]
            assert len(gc.get_objects()) > before
            await host.load("countserver")
            assert len(gc.get_objects()) < before / 10
            assert len(kept) == before


async def test_an_instance_set_aside_and_then_unloaded_is_freed() -> None:
    async with ComponentHost(clock=ScaledClock(1)) as host:
        async with serve(_config(), host=host):
            await host.load("demo")
            await host.load("countserver")       # and the demo instance is set aside again with everything
            demo = weakref.ref(host.get("demo"))       # the component itself (a local instance)
            assert demo() is not None
            await host.unload("demo")
            # Its cycles (tasks, bound methods, ports) are garbage a full pass frees, frozen or not.
            assert demo() is None
            assert host.get("countserver") is not None
