"""Acceptance 3: declared exceptions as generated classes, interruptions naming the interrupter, timeouts."""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from aiogenomix.clients import (
    ClientClosed,
    GenoMError,
    GenomixError,
    Interrupted,
    InvalidInput,
    NotFound,
    RemoteError,
    RequestTimeout,
    TransportError,
    aconnect,
    connect,
    remote_exception_class,
)


async def test_validate_refusal_raises_the_generated_class(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        with pytest.raises(demo.TOO_FAR_AWAY) as caught:
            await demo.GotoPosition(2)
        exc = caught.value
        assert type(exc).__name__ == "TOO_FAR_AWAY"
        assert isinstance(exc, RemoteError) and isinstance(exc, GenomixError) and isinstance(exc, GenoMError)
        assert exc.ex == "::demo::TOO_FAR_AWAY"
        assert exc.detail == {"overshoot": 1.0} and exc.overshoot == 1.0
        assert exc.service == "GotoPosition" and exc.module == "demo"
        assert "TOO_FAR_AWAY" in str(exc)
        assert demo.TOO_FAR_AWAY is remote_exception_class("::demo::TOO_FAR_AWAY")
        assert exc.request_id is not None  # a refusal is a request that ended in error, as in genom3
        # ack=True returns the handle of that request (Tcl's `&` gives its command): already ended,
        # it raises the same class.
        refused = await demo.MoveDistance(-3, ack=True)
        assert refused.done and refused.status == "error"
        with pytest.raises(demo.TOO_FAR_AWAY) as caught:
            await refused.result()
        assert caught.value.request_id == refused.id and caught.value.overshoot == pytest.approx(2.0)
        assert client.pending() == []


def test_interruption_names_the_interrupting_service(threaded_gateway_url: str) -> None:
    with connect(threaded_gateway_url) as client:
        demo = client.load("demo")
        moving = demo.GotoPosition(-1, ack=True)
        assert demo.Stop() is None
        with pytest.raises(Interrupted) as caught:
            moving.result(timeout=30)
        assert caught.value.by == "Stop"
        assert caught.value.request_id == moving.id
        assert "interrupted by Stop" in str(caught.value)
        assert moving.status == "error" and moving.exception is caught.value

        first = demo.GotoPosition(1, ack=True)
        second = demo.MoveDistance(0.1, ack=True)             # interrupts GotoPosition
        with pytest.raises(Interrupted, match="MoveDistance"):
            first.result()
        second.abort()
        with pytest.raises(Interrupted) as caught:
            second.result()
        assert caught.value.by == "abort"


def test_timeout_leaves_the_request_abortable(threaded_gateway_url: str) -> None:
    with connect(threaded_gateway_url) as client:
        demo = client.load("demo")
        with pytest.raises(RequestTimeout) as caught:
            demo.GotoPosition(-1, timeout=0.01)
        assert isinstance(caught.value, TimeoutError)
        request = caught.value.request
        assert request is not None and request.status == "sent" and not request.done
        assert client.pending() == [request]
        with pytest.raises(RequestTimeout):
            request.result(timeout=0)
        assert request.wait(0) is False
        request.abort()
        assert request.status == "error"
        with pytest.raises(Interrupted) as interrupted:
            request.result()
        assert interrupted.value.by == "abort"
        assert client.pending() == []


async def test_client_default_timeout_applies(gateway_url: str) -> None:
    async with aconnect(gateway_url, timeout=0.01) as client:
        demo = await client.load("demo", timeout=30)
        with pytest.raises(RequestTimeout) as caught:
            await demo.GotoPosition(1)
        await caught.value.request.abort(timeout=30)
        assert await demo.GotoPosition(demo.__info__["services"][0]["parameters"][0]["default"], timeout=None) is None


async def test_a_send_reply_slower_than_the_timeout_still_gives_the_request(gateway_url: str,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    # A loaded gateway takes longer than the call's timeout to reply to the send: the call still
    # times out, with the request the gateway started, which can be aborted (not left running unseen).
    async with aconnect(gateway_url, timeout=0.01) as client:
        demo = await client.load("demo", timeout=30)
        gateway = client._gateway
        assert gateway is not None
        reply = gateway.get

        async def slow_reply(path: str, *args: Any, timeout: float | None = None, **kwargs: Any) -> Any:
            try:  # under the timeout as the real reply is
                async with asyncio.timeout(timeout):
                    await asyncio.sleep(0.05 if "/send/" in path else 0)  # the gateway's delay, not a wait of the test
                    return await reply(path, *args, timeout=timeout, **kwargs)
            except TimeoutError:
                raise RequestTimeout(f"GET {path} got no reply within {timeout} s") from None

        monkeypatch.setattr(gateway, "get", slow_reply)
        with pytest.raises(RequestTimeout) as caught:
            await demo.GotoPosition(1)
        request = caught.value.request
        assert request is not None and not request.done
        await request.abort(timeout=30)
        assert request.status == "error"


async def test_gateway_errors_map_to_the_tree(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        with pytest.raises(NotFound) as caught:
            await client.load("nosuch")
        assert caught.value.ex == "::genomix::no_such_module"
        with pytest.raises(NotFound):
            await client.module("demo")                       # not loaded yet
        demo = await client.load("demo")
        with pytest.raises(InvalidInput):
            await client.load("demo", "-i")                   # -i without a name
        with pytest.raises(TypeError, match="posRef"):
            await demo.GotoPosition("far")
        with pytest.raises(TypeError, match="unexpected keyword"):
            await demo.GotoPosition(pos=1)
        with pytest.raises(ValueError, match="VERY_FAST"):
            await demo.SetSpeed("VERY_FAST")
        with pytest.raises(AttributeError, match="no service, port or exception 'Goto'"):
            demo.Goto  # noqa: B018
        with pytest.raises(AttributeError):
            demo._repr_html_  # noqa: B018 - private names are never looked up remotely


async def test_unreachable_gateway_is_a_transport_error() -> None:
    with pytest.raises(TransportError):
        await aconnect("127.0.0.1:1")


async def test_calls_after_close_raise_client_closed(gateway_url: str) -> None:
    client = await aconnect(gateway_url)
    demo = await client.load("demo")
    await client.aclose()
    await client.aclose()                                     # idempotent
    with pytest.raises(ClientClosed):
        await demo.GetSpeed()
