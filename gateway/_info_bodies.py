"""The ``/module/M/info`` reply bodies: each loaded instance's description, encoded once.

Building a component's description (its services with their parameters and
defaults, exceptions, ports and tasks) and encoding it took about 175 µs a
request, the larger part of a routed ``/info``.  Nothing in it changes while the
instance is loaded, so a component describes itself once
(``Component.description``) and the gateway keeps the encoded body beside the
description it encodes: the body is encoded again only when the instance
describes itself with another object (a replay once its recording's ports are
known).  The bodies are weakly keyed by their instance: one unloaded takes its
body with it, and one loaded again under the same name is a new instance with a
body of its own.
"""

from __future__ import annotations

import weakref
from typing import Any

from ..components.core.runtime import LoadedInstance
from ._replies import dumps

__all__ = ["InfoBodies"]


class InfoBodies:
    """The encoded ``/info`` description of each loaded instance, made at its first request."""

    def __init__(self) -> None:
        self._kept: weakref.WeakKeyDictionary[LoadedInstance, tuple[dict[str, Any], bytes]] = (
            weakref.WeakKeyDictionary())

    def body(self, instance: LoadedInstance) -> bytes:
        """The JSON of *instance*'s description, encoded once for as long as it describes itself the same."""
        description = instance.description()
        kept = self._kept.get(instance)
        if kept is None or kept[0] is not description:
            kept = self._kept[instance] = (description, dumps(description))
        return kept[1]
