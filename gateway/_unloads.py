"""The end of a component instance as a future, for the streams that watch its ports.

A ``watch`` stream waits on its port; once the instance is unloaded (or
killed, which unloads it) no publication will ever come, and an instance loaded
again under the same name has ports of its own.  So the stream also waits on
the instance's end, and stops there.
"""

from __future__ import annotations

import asyncio

from ..components.core import ComponentHost
from ..components.core.runtime import LoadedInstance

__all__ = ["Unloads"]


class Unloads:
    """One future per watched instance, done when that instance is unloaded.

    Args:
        host: The host whose instances are watched.
    """

    def __init__(self, host: ComponentHost) -> None:
        self._host = host
        self._futures: dict[LoadedInstance, asyncio.Future[None]] = {}

    def _loaded(self, component: LoadedInstance) -> bool:
        return self._host.instances.get(component.instance) is component

    def of(self, component: LoadedInstance) -> asyncio.Future[None]:
        """A future done when *component* is unloaded (already done if it is); never cancel it (it is shared)."""
        future = self._futures.get(component)
        if future is None:
            future = asyncio.get_running_loop().create_future()
            if self._loaded(component):
                self._futures[component] = future
            else:
                future.set_result(None)
        return future

    def notice(self, name: str) -> None:
        """The host's unload listener: end the futures of every instance that is no longer loaded.

        Matched by object, not by *name*: by the time the listeners run, an
        instance of the same name may have been loaded again.
        """
        for component in [c for c in self._futures if not self._loaded(c)]:
            future = self._futures.pop(component)
            if not future.done():
                future.set_result(None)
