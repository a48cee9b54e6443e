"""The Zenoh key space of a component host and the messages on it, sans I/O.

Every instance ``M`` a host offers lives under ``aiogenomix/M/``::

    aiogenomix/alive/M            liveliness token: M runs (gone: its process died or was cut off)
    aiogenomix/M/info             query: the /info description (JSON)
    aiogenomix/M/rq/send          query: {"service", "input", "session", "oneway"} -> status object
    aiogenomix/M/rq/status        query: {"id"} -> status object
    aiogenomix/M/rq/abort         query: {"id"} -> status object
    aiogenomix/M/rq/clean         query: {"id"} -> null
                                  (every rq query may carry "cleaned": the ids of requests the gateway
                                  saw end and cleaned itself, applied first; with no query to carry
                                  them, they are a publication {"ids"} on this key)
    aiogenomix/M/events           publication: {"status": status object, "session"} per change (none
                                  for a request whose end the send reply carried)

Every status object the host sends also has ``serial``, the request's incarnation: numbers are
reused after a clean, and the gateway drops news of a serial it already cleaned.
    aiogenomix/M/port/P           publication: port P's data, once per publication (binary, below)
    aiogenomix/M/snapshot/P       query: port P's whole data now (same form)

A query reply is ``{"ok": result}`` or ``{"error": {"status": HTTP status, "body": genomix error}}``: the
error the gateway answers for the same fault in-process, so a remote component fails identically.

Port messages use the binary layout of port reads (``AGXB``, see ``gateway/_binary.py``); the header's
``data`` is ``{"whole": ..., "delta": ...}`` with:

* ``whole``: the port's whole data as a read gives it, its arrays replaced by ``{"$len": n}``;
* ``delta``: for numbered data (:class:`~aiogenomix.components.core.Incremental`, the audio window) the
  items published since the previous message (``prev`` < item <= ``index``), arrays included; for other
  data the whole data itself.  A ``base`` message carries the whole window instead, with ``held``: how
  many of its last elements per array are numbered items (the rest is the zero padding of a window
  that has not filled yet).
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
import orjson

from ...components.core import ChunkedArray
from .._binary import MAGIC, encode_binary

__all__ = [
    "PREFIX", "alive_key", "info_key", "request_key", "events_key", "port_key", "snapshot_key",
    "ok_reply", "error_reply", "encode_message", "decode_message", "strip_arrays", "arrays_of",
]

PREFIX = "aiogenomix"


def alive_key(instance: str) -> str:
    """The liveliness token of *instance* (``*`` for every instance)."""
    return f"{PREFIX}/alive/{instance}"


def info_key(instance: str) -> str:
    """The description query of *instance*."""
    return f"{PREFIX}/{instance}/info"


def request_key(instance: str, operation: str) -> str:
    """The query of a request operation (``send``, ``status``, ``abort``, ``clean``; ``*`` for all)."""
    return f"{PREFIX}/{instance}/rq/{operation}"


def events_key(instance: str) -> str:
    """The publication of *instance*'s request status changes."""
    return f"{PREFIX}/{instance}/events"


def port_key(instance: str, port: str) -> str:
    """The publication of a port's data (``*`` for every port)."""
    return f"{PREFIX}/{instance}/port/{port}"


def snapshot_key(instance: str, port: str) -> str:
    """The query of a port's whole data now (``*`` for every port)."""
    return f"{PREFIX}/{instance}/snapshot/{port}"


def ok_reply(result: Any) -> bytes:
    """The reply of a query that succeeded."""
    return orjson.dumps({"ok": result}, option=orjson.OPT_SERIALIZE_NUMPY)


def error_reply(status: int, body: dict[str, Any]) -> bytes:
    """The reply of a query the component refused (*status* and *body* as the gateway answers them)."""
    return orjson.dumps({"error": {"status": status, "body": body}})


def arrays_of(value: Any, found: list[Any]) -> None:
    """Append every array (numpy or chunked) of JSON-ready *value* to *found*, in order.

    The order is the order of :func:`strip_arrays` and of the binary layout.
    """
    if isinstance(value, dict):
        for item in value.values():
            arrays_of(item, found)
    elif isinstance(value, list):
        for item in value:
            arrays_of(item, found)
    elif isinstance(value, (np.ndarray, ChunkedArray)):
        found.append(value)


def strip_arrays(value: Any) -> Any:
    """*value* with each array replaced by ``{"$len": n}`` (its length), for the ``whole`` skeleton."""
    if isinstance(value, dict):
        return {key: strip_arrays(item) for key, item in value.items()}
    if isinstance(value, list):
        return [strip_arrays(item) for item in value]
    if isinstance(value, (np.ndarray, ChunkedArray)):
        return {"$len": len(value)}
    return value


def encode_message(port: str, whole: Any, delta: Any, **extra: Any) -> bytes:
    """One port message: the *whole* skeleton (no arrays) and the *delta* data (with its arrays)."""
    parts = encode_binary(port, {"whole": strip_arrays(whole), "delta": delta}, **extra)
    return b"".join(parts)


def decode_message(buffer: bytes) -> tuple[dict[str, Any], Any, Any]:
    """Split a port message into its header, ``whole`` skeleton and ``delta`` data (arrays read-only, not copied).

    Raises:
        ValueError: for bytes that are not a port message.
    """
    if buffer[:4] != MAGIC:
        raise ValueError("not an aiogenomix port message")
    (size,) = struct.unpack_from("<I", buffer, 4)
    header = orjson.loads(buffer[8:8 + size])
    payload = memoryview(buffer)[8 + size:]
    arrays = [np.frombuffer(payload, dtype=np.dtype(a["dtype"]), count=int(np.prod(a["shape"])),
                            offset=a["offset"]).reshape(a["shape"]) for a in header.pop("arrays")]
    data = _fill(header.pop("data"), arrays)
    return header, data["whole"], data["delta"]


def _fill(value: Any, arrays: list[np.ndarray]) -> Any:
    if isinstance(value, dict):
        if len(value) == 1 and "$array" in value:
            return arrays[value["$array"]]
        return {key: _fill(item, arrays) for key, item in value.items()}
    if isinstance(value, list):
        return [_fill(item, arrays) for item in value]
    return value
