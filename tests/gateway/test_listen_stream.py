"""The listen stream as raw bytes: no chunked coding, one flushed block per event."""

from __future__ import annotations

import json

import aiohttp

from tests.conftest import RawEventStream


async def test_raw_socket_client_reads_event_blocks(gateway: str, http: aiohttp.ClientSession) -> None:
    stream = await RawEventStream.open(gateway, "raw")
    try:
        head = stream.headers.decode().lower()
        assert head.startswith("http/1.1 200")
        assert "content-type: text/event-stream" in head
        assert "transfer-encoding" not in head
        assert "content-length" not in head

        await http.get("/load/demo")
        async with http.get("/module/demo/send/GetSpeed", params={"s": "raw"}) as reply:
            assert (await reply.json())["status"] == "done"
        block = await stream.next_block()
        # Exactly "event:" then "data:" then a blank line: no chunk-size lines around them.
        lines = block.split(b"\n")
        assert lines[0] == b"event: request"
        assert lines[1].startswith(b"data: ")
        assert lines[2:] == [b"", b""]
        assert json.loads(lines[1][6:]) == {"id": "demo::0", "status": "done",
                                             "output": {"speedRef": "::demo::SLOW"}}
    finally:
        stream.close()


async def test_quit_ends_the_stream_and_unload_reaches_every_session(gateway: str,
                                                                    http: aiohttp.ClientSession) -> None:
    first = await RawEventStream.open(gateway, "one")
    second = await RawEventStream.open(gateway, "two")
    try:
        await http.get("/load/demo")
        async with http.get("/unload/demo") as reply:
            assert reply.status == 200
        assert await first.next_event() == ("unload", '"demo"')
        assert await second.next_event() == ("unload", '"demo"')
        async with http.get("/session/stop", params={"s": "one"}) as reply:
            assert reply.status == 200 and reply.headers["Content-Length"] == "0"
        assert await first.next_event() == ("quit", None)
        assert await first.reader.read() == b""  # the stream ends after quit
    finally:
        first.close()
        second.close()


async def test_events_sent_before_listening_are_delivered(gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    async with http.get("/module/demo/send/GetSpeed", params={"s": "late"}) as reply:
        assert (await reply.json())["status"] == "done"
    stream = await RawEventStream.open(gateway, "late")
    try:
        name, data = await stream.next_event()
        assert name == "request" and json.loads(data or "")["id"] == "demo::0"
    finally:
        stream.close()


async def test_events_after_a_listener_vanished_wait_for_the_next_one(gateway: str,
                                                                     http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    gone = await RawEventStream.open(gateway, "flaky")
    gone.close()
    await gone.writer.wait_closed()
    await http.get("/version")  # one more loop turn on the gateway: it has read the listener's FIN
    # The gateway notices the closed connection at delivery: the event waits in the backlog.
    async with http.get("/module/demo/send/GetSpeed", params={"s": "flaky"}) as reply:
        request_id = (await reply.json())["id"]
    back = await RawEventStream.open(gateway, "flaky")
    try:
        name, data = await back.next_event()
        assert name == "request" and json.loads(data or "")["id"] == request_id
    finally:
        back.close()
