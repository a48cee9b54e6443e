"""What was commanded when: a host's requests and events beside the ports, and read back, and as CSV.

The ``recorder`` component subscribes to its host's events (``host.events``: a session's, or
all) and writes each one twice:

* on ``/events``, as JSON, losslessly: what :meth:`Event.record
  <aiogenomix.components.core.Event.record>` says (for a request: its id, instance, service,
  input, session, status, output or exception, when it was sent), its JSON Schema in the
  channel's metadata (:data:`EVENTS_SCHEMA`, under the same key as the ports' JSON channels);
* on ``/events/log``, as the ``foxglove_msgs/msg/Log`` robotics tools show in their log panels
  (one line an event: ``lamp::0 Dim {"to":0.25,"seconds":1.0} done {} [lab]``, an error at the
  error level), as the live view shows them.

Each message's ``publish_time`` is the event's time on the rig's clock, the clock the ports'
captures are stamped with, so that a command sits among the data it caused; its ``log_time``
when the recorder received it (decisions 0031 and 0040).  :func:`write_events_csv` writes them as
``events.csv``, one row an event, with those of the sessions ``aiogenomix-record --session``
listened to (:func:`listened_record`: what their listen streams said).
"""

from __future__ import annotations

import csv
import dataclasses
from collections.abc import Callable, Iterable
from typing import Any, TextIO

import orjson

from ..core import Event
from ._cdr import Field, MessageType
from ._messages import TIME
from ._ports import ROLE_KEY, SCHEMA_KEY, RecordedPort, _ns, _time
from ._writer import RecordingWriter

__all__ = ["HostEventRecorder", "RecordedEvent", "EVENTS_SCHEMA", "EVENT_COLUMNS", "LOG", "EVENTS_TOPIC",
           "write_events_csv", "listened_record", "log_line"]

#: The channel of the events as JSON, and of their log lines.
EVENTS_TOPIC, LOG_TOPIC = "/events", "/events/log"
#: The role of both channels in their metadata.
EVENTS_ROLE = "host events"

_NULLABLE_STRING = {"type": ["string", "null"]}
#: The JSON Schema of a message on ``/events``.
EVENTS_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": "aiogenomix host event",
    "description": "What happened on a component host: a request sent or ended, an instance loaded or unloaded, a "
                   "session ended, an instance offered",
    "type": "object",
    "required": ["event", "time"],
    "properties": {
        "event": {"type": "string", "description": "request, load, unload, quit or offered"},
        "time": {"type": "number", "description": "When, in POSIX seconds of the rig's clock"},
        "data": {"description": "What a session's listeners are told (load, unload, quit, offered)"},
        "id": {"type": "string", "description": "The request's id, instance::number"},
        "instance": {"type": "string", "description": "The instance the request was sent to"},
        "service": {"type": "string", "description": "The service it called (empty: not known here)"},
        "input": {"description": "The input it was given, as a client sends it"},
        "session": {**_NULLABLE_STRING, "description": "The session it was sent in (null: none)"},
        "sent": {"type": ["number", "null"], "description": "When it was sent, POSIX seconds of the rig's clock"},
        "status": {"type": "string", "enum": ["sent", "done", "error"]},
        "output": {"description": "Its output, once done"},
        "exception": {"description": "Its exception ({ex, detail}), once ended in error"},
    },
}

#: A log line, as robotics tools show in their log panels (levels: 1 debug, 2 info, 3 warning, 4 error).
LOG = MessageType("foxglove_msgs/msg/Log", (
    Field("timestamp", TIME), Field("level", "uint8"), Field("message", "string"), Field("name", "string"),
    Field("file", "string"), Field("line", "uint32")))
_INFO, _ERROR = 2, 4

#: The columns of ``events.csv``.
EVENT_COLUMNS = ("time_s", "event", "session", "id", "instance", "service", "input", "status", "sent_time_s",
                 "output", "exception", "data", "receive_time_s")


class HostEventRecorder(RecordedPort):
    """Writes a host's events (:class:`~aiogenomix.components.core.Event`) on ``/events`` and ``/events/log``.

    Args:
        writer: The recording's writer.
        whose: Whose events: a session's name, or ``""`` for every event of the host.
        log_time: The recorder's clock, in nanoseconds (monotonic).
    """

    def __init__(self, writer: RecordingWriter, whose: str, log_time: Callable[[], int]) -> None:
        super().__init__("events")
        self.writer, self._log_time = writer, log_time
        metadata = {ROLE_KEY: EVENTS_ROLE, "aiogenomix.events": whose or "all"}
        self._json = writer.channel(EVENTS_TOPIC, "json", 0,
                                    {**metadata, SCHEMA_KEY: orjson.dumps(EVENTS_SCHEMA).decode()})
        schema = writer.schema(LOG.name, "ros2msg", LOG.definition().encode())
        self._log = writer.channel(LOG_TOPIC, "cdr", schema, metadata)

    def __call__(self, event: Event) -> None:
        """Write *event* (a subscriber of ``host.events``: it never blocks)."""
        now, stamp = self._log_time(), _ns(event.time)
        record = event.record()
        self.publications += 1
        self.writer.message(self._json, now, stamp, self.publications, orjson.dumps(record, option=_JSON))
        level = _ERROR if record.get("status") == "error" else _INFO
        self.writer.message(self._log, now, stamp, self.publications, LOG.encode({
            "timestamp": _time(event.time), "level": level, "message": log_line(record),
            "name": str(record.get("instance") or "aiogenomix"), "file": "", "line": 0}))
        self.messages += 2


_JSON = orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS


def _json(value: Any) -> str:
    return "" if value is None else orjson.dumps(value, option=_JSON).decode()


def log_line(record: dict[str, Any]) -> str:
    """An event's record in one line: ``lamp::0 Dim {"to":0.25} done {}`` (session in brackets)."""
    if record["event"] != "request":
        return f"{record['event']} {_json(record.get('data'))}"
    status = record["status"]
    said = _json(record.get("output") if status == "done" else record.get("exception")) if status != "sent" else ""
    session = f" [{record['session']}]" if record.get("session") else ""
    return " ".join(p for p in (record["id"], record["service"], _json(record["input"]), status, said) if p) + session


@dataclasses.dataclass(frozen=True)
class RecordedEvent:
    """One recorded host event.

    Attributes:
        record: What it said (:data:`EVENTS_SCHEMA`): ``event`` and ``time``, and a request's members.
        time: Its time on the rig's clock (POSIX seconds).
        receive_time: When the recorder received it.
    """

    record: dict[str, Any]
    time: float
    receive_time: float


def listened_record(session: str, event: str, data: Any) -> dict[str, Any]:
    """The record (:data:`EVENTS_SCHEMA`) of an event a session's listen stream told (a request's status, or data)."""
    record: dict[str, Any] = {"event": event, "session": session}
    if event == "request" and isinstance(data, dict) and isinstance(data.get("id"), str):
        instance, _, _ = data["id"].rpartition("::")
        record.update(instance=instance, service="", input=None, **data)
    else:
        record["data"] = data
    return record


def write_events_csv(events: Iterable[RecordedEvent], table: TextIO) -> int:
    """Write *events* as CSV (:data:`EVENT_COLUMNS`, JSON in the input, output and exception cells); return the rows."""
    writer = csv.writer(table)
    writer.writerow(EVENT_COLUMNS)
    rows = 0
    for event in events:
        record = event.record
        writer.writerow((f"{event.time:.9f}", record["event"], record.get("session") or "", record.get("id", ""),
                         record.get("instance", ""), record.get("service", ""), _json(record.get("input")),
                         record.get("status", ""), "" if record.get("sent") is None else f"{record['sent']:.9f}",
                         _json(record.get("output")), _json(record.get("exception")), _json(record.get("data")),
                         f"{event.receive_time:.9f}"))
        rows += 1
    return rows

