"""The ``genom_state`` port of every component: its tasks, their timings and running activities."""

from __future__ import annotations

from dataclasses import field
from typing import Any

from ._types import Double, String, ULong, idl_struct

__all__ = ["GenomState"]


@idl_struct("genom::state::timings")
class Timings:
    """Duration of a task's cycles, in seconds."""

    last: Double = 0.0
    max: Double = 0.0
    avg: Double = 0.0


@idl_struct("genom::state::rusage")
class Rusage:
    """How much a task ran."""

    cycles: ULong = 0
    timings: Timings = field(default_factory=Timings)


@idl_struct("genom::state::activity")
class ActivityState:
    """A running activity of a task."""

    id: ULong = 0
    name: String = ""


@idl_struct("genom::state::task")
class TaskState:
    """One task of the component."""

    name: String = ""
    rusage: Rusage = field(default_factory=Rusage)
    activity: list[ActivityState] = field(default_factory=list)


@idl_struct("genom::state::component")
class GenomState:
    """The data of the ``genom_state`` port."""

    task: list[TaskState] = field(default_factory=list)
    digest: String = ""
    date: String = ""
    version: String = ""

    @classmethod
    def build(cls, tasks: list[dict[str, Any]], digest: str, date: str, version: str) -> GenomState:
        """Build the state from plain task dictionaries."""
        built = []
        for task in tasks:
            usage = task["rusage"]
            built.append(TaskState(
                name=task["name"],
                rusage=Rusage(cycles=usage["cycles"], timings=Timings(**usage["timings"])),
                activity=[ActivityState(**a) for a in task["activity"]],
            ))
        return cls(task=built, digest=digest, date=date, version=version)
