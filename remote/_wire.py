"""The Zenoh key space of component hosts and gateways, and the messages on it, sans I/O.

Remote protocol 2.  A host process is known by its Zenoh session id ``Z`` (one per run) and named by
its host id ``H`` (``aiogenomix-component --host-id``); a gateway by its session id ``G``::

    aiogenomix/offer/2/H/Z/M          liveliness token: host H (session Z) offers instance M
    aiogenomix/gateway/2/G            liveliness token: gateway G may have requests running (dead-man)
    aiogenomix/hear/2/L/MS            liveliness token: process L (a gateway, or a host that reads another
                                      host's ports) hears heartbeats, and needs one every MS milliseconds
    aiogenomix/2/Z/host               query: the host's facts (id, endpoints, versions, instances)
    aiogenomix/2/Z/beat               publication: the host is heard from, every MS milliseconds of the
                                      shortest hear token (BEAT_PERIOD while a gateway without one is there,
                                      or no process says how often it needs a beat)
    aiogenomix/2/Z/M/info             query: the /info description (JSON)
    aiogenomix/2/Z/M/rq/send          query: {"service", "input", "session", "oneway", "gateway", "via"}
                                      -> status object ("via": the proxy of the gateway that sends it)
    aiogenomix/2/Z/M/rq/status        query: {"id", "gateway"} -> status object
    aiogenomix/2/Z/M/rq/abort         query: {"id", "gateway"} -> status object
    aiogenomix/2/Z/M/rq/clean         query: {"id", "gateway"} -> null
    aiogenomix/2/Z/M/rq/release       query: {"gateway", "via"} -> {"ended": [status object...]}: the proxy
                                      was unloaded: its running motions are interrupted (by kill), and
                                      the component's stop_motions runs when it sent the last motion
                                      (every rq query may carry "cleaned": the ids of requests the gateway
                                      saw end and cleaned itself, applied first; with no query to carry
                                      them, they are a publication {"ids"} on .../M/cleaned/G)
    aiogenomix/2/Z/M/events/G         publication: {"status": status object, "session"} per change of a
                                      request gateway G sent (none for a request whose end the send reply
                                      carried): no other gateway hears of it
    aiogenomix/2/Z/M/port/P           publication: port P's data, once per publication (binary, below)
    aiogenomix/2/Z/M/snapshot/P       query: port P's whole data now (same form)

A request belongs to the gateway that sent it: another gateway's ``status``, ``abort`` or ``clean`` of
it is refused as an unknown request.  Every status object the host sends also has ``serial``, the
request's incarnation: numbers are reused after a clean, and the gateway drops news of a serial it
already cleaned.  A host of protocol 1 declared ``aiogenomix/alive/M``: a gateway sees it and refuses it.

A query reply is ``{"ok": result}`` or ``{"error": {"status": HTTP status, "body": genomix error}}``: the
error the gateway answers for the same fault in-process, so a remote component fails identically.

Port messages use the binary layout of port reads (``AGXB``, ``encode_binary``); the header's
``data`` is ``{"whole": ..., "delta": ...}`` with:

* ``whole``: the port's whole data as a read gives it, its arrays replaced by ``{"$len": n}``;
* ``delta``: for numbered data (:class:`~aiogenomix.components.core.Incremental`, the audio window) the
  items published since the previous message (``prev`` < item <= ``index``), arrays included; for other
  data the whole data itself.  A ``base`` message carries the whole window instead, with ``held``: how
  many of its last elements per array are numbered items (the rest is the zero padding of a window
  that has not filled yet).

A ``withdrawn`` message (no data) says the component withdrew the port's data, with ``reason``: its
exception object.  The next publication is a whole message again.
"""

from __future__ import annotations

import dataclasses
import re
import struct
from typing import Any

import numpy as np
import orjson

from ..components.core import ChunkedArray
from ..components.core.runtime import BINARY_MAGIC, encode_binary

__all__ = [
    "PROTOCOL", "OFFERS", "LEGACY_OFFERS", "GATEWAYS", "BEATS", "BEAT_PERIOD", "HEARERS", "OfferKey", "offer_token",
    "parse_offer", "offers_of", "legacy_offer", "gateway_token", "hear_token", "parse_hear", "beat_period",
    "host_id_error", "facts_key", "beat_key",
    "info_key", "request_key", "events_key", "cleaned_key", "port_key", "snapshot_key", "ok_reply", "error_reply",
    "encode_message", "decode_message", "strip_arrays", "arrays_of",
]

#: The version of the key space and messages: a gateway and a host of different versions refuse each other.
PROTOCOL = 2
_ROOT = "aiogenomix"
#: Every offer of every protocol version (one with another version than ours is refused, and said so).
OFFERS = f"{_ROOT}/offer/**"
#: The offers of protocol 1 hosts (``aiogenomix/alive/M``).
LEGACY_OFFERS = f"{_ROOT}/alive/*"
#: Every gateway's liveliness token.
GATEWAYS = f"{_ROOT}/gateway/{PROTOCOL}/*"
#: Every host's heartbeat.
BEATS = f"{_ROOT}/{PROTOCOL}/*/beat"
#: Seconds between two heartbeats of a host when no process that hears them said how often it needs one
#: (a gateway of before the hear tokens has a bound of 0.5 s at the least: two beats within it).
BEAT_PERIOD = 0.25
#: Every hear token: the processes that hear heartbeats, and how often each needs one.
HEARERS = f"{_ROOT}/hear/{PROTOCOL}/*/*"
#: Heartbeats a hearer asks within its stale bound: three may be late or lost before its hosts are stale.
BEATS_PER_BOUND = 4

#: What a host id may be: one key chunk, no wildcard or separator Zenoh or a load name gives a meaning to.
_HOST_ID = re.compile(r"[A-Za-z0-9_.-]{1,64}")
#: What a Zenoh session id is: its hexadecimal form.
_ZID = re.compile(r"[0-9a-f]{1,32}")


def host_id_error(host_id: str) -> str | None:
    """Why *host_id* cannot name a component host (None: it can)."""
    if not _HOST_ID.fullmatch(host_id):
        return (f"{host_id!r} cannot be a host id: use 1 to 64 letters, digits, '.', '_' or '-' "
                f"(it names the host in loads such as demo@HOST)")
    return None


@dataclasses.dataclass(frozen=True)
class OfferKey:
    """One offer, read from its liveliness token.

    Attributes:
        protocol: The remote protocol version of the host.
        host: The host id (empty for another protocol's offer).
        zid: The host's Zenoh session id (empty likewise).
        instance: The instance offered (for another protocol's offer: the key's last chunk).
        key: The token's key, as it came.
    """

    protocol: int
    host: str
    zid: str
    instance: str
    key: str

    @property
    def name(self) -> str:
        """``instance@host``: the load name that designates this offer whoever else offers the instance."""
        return f"{self.instance}@{self.host}"


def offer_token(host: str, zid: str, instance: str) -> str:
    """The liveliness token of *instance* offered by host *host* (session *zid*)."""
    return f"{_ROOT}/offer/{PROTOCOL}/{host}/{zid}/{instance}"


def parse_offer(key: str) -> OfferKey | None:
    """The offer a token's *key* declares (None for a key that is no offer)."""
    chunks = key.split("/")
    if len(chunks) == 3 and chunks[:2] == [_ROOT, "alive"]:
        return OfferKey(1, "", "", chunks[2], key)
    if len(chunks) < 3 or chunks[:2] != [_ROOT, "offer"]:
        return None
    try:
        protocol = int(chunks[2])
    except ValueError:
        return None
    if protocol == PROTOCOL:
        # Ours: exactly host, session and instance, each what they can be; anything else is no offer
        # (a host and session left empty would make a name ambiguous for good, or a key of nothing).
        if len(chunks) != 6:
            return None
        host, zid, instance = chunks[3:]
        if host_id_error(host) is not None or not _ZID.fullmatch(zid) or not instance.isidentifier():
            return None
        return OfferKey(protocol, host, zid, instance, key)
    # Another version's layout is not ours to read: its last chunk is taken for the instance, to name it
    # when its load is refused.
    return OfferKey(protocol, "", "", chunks[-1], key)


def offers_of(instance: str) -> str:
    """Every offer of *instance*, by any host, of any protocol version that keeps the instance last."""
    return f"{_ROOT}/offer/**/{instance}"


def legacy_offer(instance: str) -> str:
    """The offer of *instance* by a host of protocol 1."""
    return f"{_ROOT}/alive/{instance}"


def gateway_token(zid: str) -> str:
    """The liveliness token of the gateway whose session is *zid*."""
    return f"{_ROOT}/gateway/{PROTOCOL}/{zid}"


def hear_token(zid: str, stale: float) -> str:
    """The liveliness token of process *zid*, which takes a host not heard from for *stale* seconds as stale."""
    return f"{_ROOT}/hear/{PROTOCOL}/{zid}/{beat_period(stale) * 1000:.0f}"


def beat_period(stale: float) -> float:
    """Seconds between two heartbeats a process whose stale bound is *stale* seconds needs (ms rounded)."""
    return max(round(stale * 1000 / BEATS_PER_BOUND), 1) / 1000


def parse_hear(key: str) -> tuple[str, float] | None:
    """The process and the seconds between two beats it needs, from a hear token's *key* (None: no such token)."""
    chunks = key.split("/")
    if len(chunks) != 5 or chunks[:3] != [_ROOT, "hear", str(PROTOCOL)] or not _ZID.fullmatch(chunks[3]):
        return None
    try:
        period = int(chunks[4])
    except ValueError:
        return None
    return (chunks[3], period / 1000) if period > 0 else None


def facts_key(zid: str) -> str:
    """The query of the host facts of session *zid*."""
    return f"{_ROOT}/{PROTOCOL}/{zid}/host"


def beat_key(zid: str) -> str:
    """The heartbeat of the host of session *zid*."""
    return f"{_ROOT}/{PROTOCOL}/{zid}/beat"


def _instance_key(zid: str, instance: str) -> str:
    return f"{_ROOT}/{PROTOCOL}/{zid}/{instance}"


def info_key(zid: str, instance: str) -> str:
    """The description query of *instance* on the host of session *zid*."""
    return f"{_instance_key(zid, instance)}/info"


def request_key(zid: str, instance: str, operation: str) -> str:
    """The query of a request operation (``send``, ``status``, ``abort``, ``clean``; ``*`` for all)."""
    return f"{_instance_key(zid, instance)}/rq/{operation}"


def events_key(zid: str, instance: str, gateway: str) -> str:
    """The publication of the status changes of the requests gateway *gateway* sent (``*``: every gateway's)."""
    return f"{_instance_key(zid, instance)}/events/{gateway}"


def cleaned_key(zid: str, instance: str, gateway: str) -> str:
    """The publication of the cleans gateway *gateway* answered itself (``*``: every gateway's)."""
    return f"{_instance_key(zid, instance)}/cleaned/{gateway}"


def port_key(zid: str, instance: str, port: str) -> str:
    """The publication of a port's data (``*`` for every port)."""
    return f"{_instance_key(zid, instance)}/port/{port}"


def snapshot_key(zid: str, instance: str, port: str) -> str:
    """The query of a port's whole data now (``*`` for every port)."""
    return f"{_instance_key(zid, instance)}/snapshot/{port}"


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
    if buffer[:4] != BINARY_MAGIC:
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
