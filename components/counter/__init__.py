"""The toy ``countserver`` and ``countclient`` components of the seed report (appendix 9.3.2).

``countserver`` increments a counter every 500 ms and publishes it on
``CounterPort``; ``countclient`` reads that port through its in port every
1000 ms, so it displays one value out of two.
"""

from __future__ import annotations

import enum
import logging
from typing import Annotated

from ..core import (
    Component, GenomException, InPort, OutPort, Out, Short, Task, ULong, activity, attribute, function,
    idl_enum, idl_struct,
)

__all__ = ["CountServer", "CountClient", "Counter", "Speed", "Display", "INVALID_SPEED",
           "INVALID_INITIAL_VALUE", "INITIAL_VALUE_LIMIT"]

log = logging.getLogger(__name__)

#: CountFrom refuses initial values beyond ±INITIAL_VALUE_LIMIT.
INITIAL_VALUE_LIMIT = 1000


@idl_struct("countserverinterface::Counter")
class Counter:
    """The counter: where it started and where it is."""

    initial: Short = 0
    current: Short = 0


@idl_enum("countserverinterface::Speed")
class Speed(enum.Enum):
    """How the counter moves at each period."""

    FASTBWD = 0
    SLOWBWD = 1
    SLOWFWD = 2
    FASTFWD = 3


_STEPS = {Speed.FASTBWD: -10, Speed.SLOWBWD: -1, Speed.SLOWFWD: 1, Speed.FASTFWD: 10}


class INVALID_SPEED(GenomException):
    """The speed is not one of the four paces."""


class INVALID_INITIAL_VALUE(GenomException):
    """The initial value is out of the accepted range."""


def _wrap_short(value: int) -> int:
    # The counter is a C short: it wraps around like one.
    return (value + 2**15) % 2**16 - 2**15


class CountServer(Component, name="countserver", version="1.0"):
    """Increments a counter on a regular time basis and publishes it."""

    count_task = Task(period=0.5, doc="Counts, every 500 ms")
    CounterPort = OutPort(Counter, doc="The current value of the counter and its initial value")

    async def on_start(self) -> None:
        """Start at zero, counting slowly forward."""
        self.counter = Counter()
        self.speed = Speed.SLOWFWD
        self.CounterPort.publish(self.counter)

    def _control_speed(self, idsSpeed: Speed) -> None:
        if idsSpeed not in _STEPS:
            raise INVALID_SPEED()

    def _control_init_value(self, initial_value: int) -> None:
        if abs(initial_value) > INITIAL_VALUE_LIMIT:
            raise INVALID_INITIAL_VALUE()

    async def _count(self) -> None:
        while True:
            await self.count_task.tick()
            current = _wrap_short(self.counter.current + _STEPS[self.speed])
            self.counter = Counter(self.counter.initial, current)
            self.CounterPort.publish(self.counter)

    @attribute(validate=_control_speed, throws=(INVALID_SPEED,))
    def SetSpeed(self, idsSpeed: Annotated[Speed, "Counting speed"] = Speed.SLOWFWD) -> None:
        """Sets current speed value."""
        self.speed = idsSpeed

    @attribute
    def GetSpeed(self) -> Annotated[Speed, Out("idsSpeed", "Counting speed")]:
        """Gets current speed value."""
        return self.speed

    @attribute
    def GetInitial(self) -> Annotated[Short, Out("initial", "Initial value of the counter")]:
        """Gets counter's initial value."""
        return self.counter.initial

    @attribute
    def GetCurrent(self) -> Annotated[Short, Out("current", "Current value of the counter")]:
        """Gets counter's current value."""
        return self.counter.current

    @activity(task=count_task, interrupts=("CountStart", "CountFrom"))
    async def CountStart(self) -> None:
        """Starts the counter."""
        await self._count()

    @activity(task=count_task, interrupts=("CountStart", "CountFrom"), validate=_control_init_value,
              throws=(INVALID_INITIAL_VALUE,))
    async def CountFrom(self, initial_value: Annotated[Short, "Initial value of the counter"] = 0) -> None:
        """Starts the counter from given value."""
        self.counter = Counter(initial_value, initial_value)
        self.CounterPort.publish(self.counter)
        await self._count()

    @function(interrupts=("CountStart", "CountFrom"))
    def CountStop(self) -> None:
        """Stops the counter."""


@idl_struct("countclient::Display")
class Display:
    """What the client displayed last, and how many times it displayed."""

    counter: Counter
    displays: ULong = 0


class CountClient(Component, name="countclient", version="1.0"):
    """Displays the counter of a countserver, read through its in port every second."""

    display_task = Task(period=1.0, doc="Displays the counter, every 1000 ms")
    CounterPort = InPort(Counter, doc="Connect to countserver/CounterPort with connect_port")
    Displayed = OutPort(Display, doc="The last value displayed")

    @display_task.periodic
    def _display(self) -> None:
        counter = self.CounterPort.read()
        if counter is None:
            return
        shown = self.Displayed.read()
        self.Displayed.publish(Display(counter=counter, displays=shown.displays + 1))
        log.info("%s: counter %d (initial %d)", self.instance, counter.current, counter.initial)
