"""A private event loop in a daemon thread, on which the synchronous facade runs the async core.

Running the core on its own loop, rather than ``asyncio.run`` per call, keeps
the event stream open between calls, and works where the calling thread
already runs a loop (Jupyter's kernel, an async test).
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from ._ctrl_c import result_of
from ._errors import ClientClosed

__all__ = ["LoopThread"]

T = TypeVar("T")


class LoopThread:
    """One asyncio event loop running for ever in a named daemon thread.

    Args:
        name: The thread name (shown in tracebacks and debuggers).
    """

    def __init__(self, name: str = "aiogenomix-client") -> None:
        self.loop = asyncio.new_event_loop()
        self._closed = False
        self._thread = threading.Thread(target=self._main, name=name, daemon=True)
        self._thread.start()

    def _main(self) -> None:
        asyncio.set_event_loop(self.loop)
        try:
            self.loop.run_forever()
            # Whatever is left (a callback's task) gets cancelled rather than abandoned.
            pending = asyncio.all_tasks(self.loop)
            for task in pending:
                task.cancel()
            if pending:
                self.loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
            self.loop.run_until_complete(self.loop.shutdown_asyncgens())
        finally:
            self.loop.close()

    @property
    def in_thread(self) -> bool:
        """Whether the caller is the loop thread itself."""
        return threading.current_thread() is self._thread

    def run(self, coro: Coroutine[Any, Any, T]) -> T:
        """Run *coro* on the loop and block until it ends; its exception is raised here.

        A KeyboardInterrupt (or any exception in the waiting thread) cancels the coroutine.

        Raises:
            RuntimeError: when called from the loop thread (it would wait for itself).
            ClientClosed: when the loop was closed.
        """
        if self.in_thread:
            coro.close()
            raise RuntimeError("a blocking aiogenomix call cannot run on the client's own event loop thread; "
                               "use ack=True or the async client there")
        if self._closed:
            coro.close()
            raise ClientClosed("the client was closed")
        future = asyncio.run_coroutine_threadsafe(coro, self.loop)
        try:
            return result_of(future)
        except BaseException:
            future.cancel()
            raise

    def call_soon(self, func: Callable[..., Any], *args: Any) -> None:
        """Schedule ``func(*args)`` on the loop from any thread."""
        if not self._closed:
            self.loop.call_soon_threadsafe(func, *args)

    def close(self) -> None:
        """Stop the loop and join the thread; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        if self.in_thread:
            self.loop.stop()  # the thread ends by itself once this callback returns
            return
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join()

