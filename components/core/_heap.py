"""The garbage collector's full passes kept short in a long-lived process: what it holds for good is set aside.

CPython's cyclic collector traverses every tracked object of its oldest generation at each full pass, and
a pass runs on the thread that allocated last: in a gateway, on its event loop. A gateway that has imported
numpy, scipy, MuJoCo and its components tracks over 100,000 objects, nearly all of them alive as long as the
process (modules, classes, functions, the loaded components), and a full pass stopped its event loop for
16-56 ms (measured beside the virtual world and its ears: the world benchmark's longest stall came from one).
:func:`gc.freeze` moves every object alive into a permanent generation that no pass traverses; objects made
afterwards are collected as before, and reference counting frees frozen objects as it frees any.

What only a pass frees is a cycle, and an instance unloaded leaves cycles among frozen objects (its tasks,
bound methods, ports): so each unload gives everything back to the collector, collects once (one pass of
the old length, while an unload takes longer anyway) and sets aside what is still alive. A load sets aside
what it imported and made, after a pass over the young generations only, which is short; the unloads of a
host that closes make no pass (its stop is bounded in time, and what it held goes with it). Garbage that
came to be among frozen objects otherwise (a session open at a load, closed later) waits for the next
unload: bounded by what was alive at the last load.
"""

from __future__ import annotations

import gc
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ._host import ComponentHost

__all__ = ["settle_heap", "keep_heap_settled"]


def settle_heap() -> None:
    """Collect every generation once, then set aside what is alive (the full passes no longer traverse it)."""
    gc.unfreeze()
    gc.collect()
    gc.freeze()


def _set_aside_young() -> None:
    gc.collect(1)
    gc.freeze()


def keep_heap_settled(host: ComponentHost) -> None:
    """Settle the heap now, and keep it settled as *host* loads and unloads instances.

    Args:
        host: The host whose loads and unloads change what the process holds.
    """
    settle_heap()
    host.add_load_listener(lambda _instance: _set_aside_young())
    # A host that closes unloads everything within a bounded time (the gateway's stop: a second), and what
    # it held is freed with it, or with the process: a pass per instance there would only cost that time.
    host.add_unload_listener(lambda _instance: None if host.closing else settle_heap())
