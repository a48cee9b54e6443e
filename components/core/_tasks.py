"""Execution tasks: periodic or aperiodic loops owned by a component (genom3 ``task``).

``motion = Task(period=0.4)`` declares a task; ``@motion.periodic`` marks a
method run once per period while the component runs; activities that belong to
the task pace themselves with ``await self.motion.tick()``.  Periods are in
runtime seconds of the host's clock, so a sped-up clock speeds up every task.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from collections.abc import Awaitable, Callable
from typing import Any

from ._log_limits import ThrottledLog

__all__ = ["Task", "TaskRuntime"]

log = logging.getLogger(__name__)
_failures = ThrottledLog(log)


class Task:
    """Declare an execution task of a component.

    Args:
        period: The period in seconds, or None for an aperiodic task.
        doc: What the task does.
    """

    def __init__(self, period: float | None = None, doc: str = "") -> None:
        if period is not None and not period > 0:
            raise ValueError(f"task period must be positive, not {period!r}")
        self.period = period
        self.doc = doc
        self.name = ""
        self.body: Callable[[Any], Awaitable[None] | None] | None = None

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def periodic(self, func: Callable[[Any], Awaitable[None] | None]) -> Callable[[Any], Any]:
        """Decorator: run *func* (a method) once per period while the component runs."""
        if self.period is None:
            raise TypeError(f"task {self.name or '?'} has no period: it cannot run a periodic body")
        self.body = func
        return func

    def __get__(self, instance: Any, owner: type) -> Any:
        if instance is None:
            return self
        return instance._task_runtime(self.name)

    def describe(self) -> dict[str, Any]:
        """The ``/info`` description of this task."""
        return {"name": self.name, "period": self.period, "doc": self.doc}


class TaskRuntime:
    """The running side of a :class:`Task` for one component instance."""

    def __init__(self, spec: Task, owner: Any) -> None:
        self.spec = spec
        self.owner = owner
        self.origin = owner.clock.now()
        self.cycles = 0
        self.last = self.max = self.total = 0.0
        self._loop_task: asyncio.Task[None] | None = None

    @property
    def name(self) -> str:
        """The task name."""
        return self.spec.name

    @property
    def period(self) -> float | None:
        """The period in runtime seconds (None when aperiodic)."""
        return self.spec.period

    async def tick(self) -> None:
        """Wait for the next period boundary of this task (one clock step when aperiodic)."""
        clock = self.owner.clock
        if self.period is None:
            await asyncio.sleep(0)
            return
        elapsed = clock.now() - self.origin
        next_index = math.floor(elapsed / self.period + 1e-9) + 1
        await clock.sleep_until(self.origin + next_index * self.period)

    def start(self) -> None:
        """Start the periodic body, if the task has one."""
        if self.spec.body is not None and self._loop_task is None:
            self._loop_task = asyncio.create_task(self._run(), name=f"{self.owner.instance}.{self.name}")

    async def stop(self) -> None:
        """Stop the periodic body and wait for it to end."""
        task, self._loop_task = self._loop_task, None
        if task is not None:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)

    async def _run(self) -> None:
        body = self.spec.body
        assert body is not None
        while True:
            await self.tick()
            started = time.perf_counter()
            try:
                result = body(self.owner)
                if asyncio.iscoroutine(result):
                    await result
            except asyncio.CancelledError:
                raise
            except Exception as exc:
                # A control loop keeps running after a bad cycle; the failure is logged (its traceback
                # once, then rate-limited lines: a loop failing at every cycle must not fill the log)
                # and counted in genom_state, not hidden.
                _failures.error("task %s.%s: periodic body failed: %s", self.owner.instance, self.name,
                                f"{type(exc).__name__}: {exc}", exc=exc)
            self._account(time.perf_counter() - started)

    def _account(self, duration: float) -> None:
        self.cycles += 1
        self.last = duration
        self.max = max(self.max, duration)
        self.total += duration

    def state(self) -> dict[str, Any]:
        """The task's entry of the ``genom_state`` port."""
        avg = self.total / self.cycles if self.cycles else 0.0
        return {"name": self.name, "rusage": {"cycles": self.cycles,
                                              "timings": {"last": self.last, "max": self.max, "avg": avg}}}
