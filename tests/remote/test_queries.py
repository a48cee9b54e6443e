"""A query between two real Zenoh sessions on loopback: each way it can end, said as what happened.

A reply; a refusal; no reply within the timeout (a frozen host); and nothing answering at all (the
queryable withdrawn, or gone with its host), which Zenoh says at once and which is no timeout.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator

import pytest
import zenoh

from aiogenomix.components.core.runtime import RemoteRefusal, RemoteUnreachable
from aiogenomix.remote._session import Unanswered, ZenohSettings, ask, open_session
from aiogenomix.remote._wire import error_reply, ok_reply

from ._processes import free_port


@contextlib.asynccontextmanager
async def pair() -> AsyncIterator[tuple[zenoh.Session, zenoh.Session]]:
    """An answering session and an asking one, linked on loopback."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    answering, _ = await asyncio.to_thread(open_session, ZenohSettings(listen=[endpoint]))
    asking, _ = await asyncio.to_thread(open_session, ZenohSettings(connect=[endpoint]))
    try:
        yield answering, asking
    finally:
        await asyncio.gather(asyncio.to_thread(asking.close), asyncio.to_thread(answering.close))


async def _declared(asking: zenoh.Session, key: str) -> None:
    """Wait until *asking* knows of a queryable on *key* (its declaration crossed the link)."""
    loop = asyncio.get_running_loop()
    matched = asyncio.Event()
    querier = asking.declare_querier(key)

    def on_status(status: zenoh.MatchingStatus) -> None:
        if status.matching:
            loop.call_soon_threadsafe(matched.set)

    listener = querier.declare_matching_listener(on_status)
    try:
        if querier.matching_status.matching:
            matched.set()
        await asyncio.wait_for(matched.wait(), 10.0)
    finally:
        listener.undeclare()
        querier.undeclare()


async def test_a_reply_and_a_refusal_are_told_apart() -> None:
    async with pair() as (answering, asking):
        answering.declare_queryable("t/ok", lambda query: query.reply(query.key_expr, ok_reply({"x": 1})))
        refusal = error_reply(404, {"ex": "::genom::no_such_service", "message": "no service 'Nope'"})
        answering.declare_queryable("t/refused", lambda query: query.reply(query.key_expr, refusal))
        await _declared(asking, "t/ok")
        assert await ask(asking, "t/ok", None, 5.0, what="ok") == {"x": 1}
        await _declared(asking, "t/refused")
        with pytest.raises(RemoteRefusal) as refused:
            await ask(asking, "t/refused", None, 5.0, what="refused")
        assert (refused.value.status, refused.value.body["ex"]) == (404, "::genom::no_such_service")


async def test_a_query_nothing_answers_ends_at_once_saying_so_not_as_a_timeout() -> None:
    async with pair() as (_, asking):
        loop = asyncio.get_running_loop()
        started = loop.time()
        with pytest.raises(Unanswered) as unanswered:
            await ask(asking, "t/withdrawn", None, 60.0, what="the description of demo@robot1")
        assert loop.time() - started < 30.0  # well before the 60 s: nobody was waited for
        assert str(unanswered.value) == ("the description of demo@robot1: nothing answers it any more (its host "
                                         "withdrew it, or went away, before answering)")


async def test_a_queryable_that_drops_its_query_unanswered_is_no_timeout() -> None:
    async with pair() as (answering, asking):
        dropped: list[str] = []

        def drop(query: zenoh.Query) -> None:
            dropped.append(str(query.key_expr))
            query.drop()

        answering.declare_queryable("t/dropped", drop)
        await _declared(asking, "t/dropped")
        with pytest.raises(Unanswered):
            await ask(asking, "t/dropped", None, 60.0, what="dropped")
        assert dropped == ["t/dropped"]


async def test_a_query_that_gets_no_reply_in_time_says_how_long_it_waited() -> None:
    async with pair() as (answering, asking):
        held: list[zenoh.Query] = []  # kept, never answered: a frozen host
        answering.declare_queryable("t/frozen", held.append)
        await _declared(asking, "t/frozen")
        with pytest.raises(RemoteUnreachable) as late:
            await ask(asking, "t/frozen", None, 0.5, what="send of demo on robot1")
        assert held, "the query reached the queryable"
        assert not isinstance(late.value, Unanswered)
        assert str(late.value) == ("send of demo on robot1: no answer within 0.5 s (its host is frozen, or the "
                                   "network between is cut)")
