"""The ``replay`` component: the ports of a recording published again, under their names, at their recorded timing."""

from ._component import NOT_PLAYING, Replay, ReplayStatus

__all__ = ["Replay", "ReplayStatus", "NOT_PLAYING"]
