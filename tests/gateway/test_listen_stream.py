"""The listen stream as raw bytes: no chunked coding, one flushed block per event."""

from __future__ import annotations

import asyncio
import json

import aiohttp
import pytest

from tests.conftest import RawEventStream
from tests.gateway._raw_http import address, open_raw


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


async def _standard_stream(gateway: str, path: str, *headers: str) -> tuple[asyncio.StreamReader,
                                                                              asyncio.StreamWriter, bytes]:
    reader, writer = await open_raw(gateway)
    lines = [f"GET {path} HTTP/1.1", f"Host: {address(gateway)[0]}", "Accept: text/event-stream", *headers]
    writer.write(("\r\n".join(lines) + "\r\n\r\n").encode())
    return reader, writer, await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 10)


async def _chunk(reader: asyncio.StreamReader) -> bytes:
    """The next chunk of a chunked body, pings skipped."""
    while True:
        size = int(await asyncio.wait_for(reader.readuntil(b"\r\n"), 10), 16)
        data = await reader.readexactly(size + 2)
        if not data.startswith(b":"):
            return data[:-2]


async def _events(reader: asyncio.StreamReader, count: int) -> list[bytes]:
    """The next *count* events of a chunked stream (a chunk may hold several)."""
    data = b""
    while data.count(b"\n\n") < count:
        data += await _chunk(reader)
    return [event + b"\n\n" for event in data.split(b"\n\n")[:count]]


async def test_a_standard_client_gets_chunks_ids_and_a_quit_with_data(gateway: str,
                                                                        http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    reader, writer, head = await _standard_stream(gateway, "/session/listen?s=std")
    try:
        assert b"transfer-encoding: chunked" in head.lower()
        for number in (1, 2):
            await http.get("/module/demo/send/GetSpeed", params={"s": "std"})
            assert (await _chunk(reader)).startswith(b"id: %d\nevent: request\ndata: {" % number)
        await http.get("/session/stop", params={"s": "std"})
        assert await _chunk(reader) == b'id: end\nevent: quit\ndata: "std"\n\n'
        assert await reader.readuntil(b"0\r\n\r\n") == b"0\r\n\r\n"  # the last chunk: the stream ended
    finally:
        writer.close()
    # The reconnect an EventSource makes after quit: 204, and the session stays stopped.
    reader, writer, head = await _standard_stream(gateway, "/session/listen?s=std", "Last-Event-ID: end")
    writer.close()
    assert head.startswith(b"HTTP/1.1 204")
    async with http.get("/session/stop", params={"s": "std"}) as reply:
        assert reply.status == 404


async def test_a_standard_listen_opened_again_gets_every_event_after_its_last_id(
        gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    reader, writer, _ = await _standard_stream(gateway, "/session/listen?s=again")
    try:
        for _ in range(3):
            await http.get("/module/demo/send/GetSpeed", params={"s": "again"})
        had = await _events(reader, 3)
        # The client's connection dropped after event 1, unnoticed by the gateway (this one is still
        # open): it opens the stream again with the id it had, and gets events 2 and 3, then new ones.
        again, again_writer, _ = await _standard_stream(gateway, "/session/listen?s=again", "Last-Event-ID: 1")
        try:
            assert await _events(again, 2) == had[1:]
            await http.get("/module/demo/send/GetSpeed", params={"s": "again"})
            assert (await _chunk(again)).startswith(b"id: 4\nevent: request\n")
        finally:
            again_writer.close()
        # An id the session never gave (from before it expired, say), or not an id at all, replays nothing.
        number = 5
        for unknown in ("99", "\u00b2", "9" * 5000, "-1"):
            fresh, fresh_writer, head = await _standard_stream(
                gateway, "/session/listen?s=again", "Last-Event-ID: " + unknown)
            try:
                assert head.startswith(b"HTTP/1.1 200")
                await http.get("/module/demo/send/GetSpeed", params={"s": "again"})
                assert (await _chunk(fresh)).startswith(b"id: %d\nevent: request\n" % number)
                number += 1
            finally:
                fresh_writer.close()
    finally:
        writer.close()


@pytest.mark.parametrize("query", ["", "?since=0"])
async def test_a_standard_watch_resumes_from_its_last_event_id_and_stops_after_unload(
        gateway: str, http: aiohttp.ClientSession, query: str) -> None:
    await http.get("/load/capture")
    # A long window (a second at the tests' time scale), so that the reconnect below loses nothing.
    await http.get("/module/capture/send/StartCapture", params={"input": '{"Port_chunks":400}'})
    watch = "/module/capture/watch/Port" + query
    reader, writer, _ = await _standard_stream(gateway, watch)
    try:
        last_chunk = 0
        while not last_chunk:  # (a watch opened before the first chunk starts with the empty port)
            first = await _chunk(reader)
            assert first.startswith(b"id: ") and b"event: port\n" in first
            last_chunk = int(first.split(b"\n")[0][4:])
        assert json.loads(first.split(b"data: ")[1])["Port"]["index"] == last_chunk
    finally:
        writer.close()
    # An EventSource reconnects to the same URL with the id it had: it gets the chunks after that id, as with
    # since=, whatever since= the URL says (where it first started).
    reader, writer, _ = await _standard_stream(gateway, watch, f"Last-Event-ID: {last_chunk}")
    try:
        resumed = json.loads((await _chunk(reader)).split(b"data: ")[1])
        port = resumed["Port"]
        chunks = port["nbframes"] // 2205  # 50 ms chunks at 44.1 kHz
        assert port["index"] - chunks + 1 == last_chunk + 1 and resumed["lost"] == 0
        await http.get("/unload/capture")
        while b"event: unload" not in (last := await _chunk(reader)):
            pass
        assert last == b'id: end\nevent: unload\ndata: "capture"\n\n'
    finally:
        writer.close()
    reader, writer, head = await _standard_stream(gateway, "/module/capture/watch/Port", "Last-Event-ID: end")
    writer.close()
    assert head.startswith(b"HTTP/1.1 204")
