"""Sends that arrive at once over HTTP interrupt each other: one motion runs, every other ends once."""

from __future__ import annotations

import asyncio
import json
from collections import Counter
from typing import Any

import aiohttp

from tests.conftest import RawEventStream

GOTO = "/module/demo/send/GotoPosition"
INTERRUPTED = {"ex": "::genom::interrupted", "detail": {"by": "GotoPosition"}}


async def get_json(http: aiohttp.ClientSession, path: str, **params: str) -> Any:
    async with http.get(path, params=params) as reply:
        assert reply.status == 200, await reply.text()
        return await reply.json()


async def test_twenty_simultaneous_gotos_leave_one_running(gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    stream = await RawEventStream.open(gateway, "burst")
    try:
        targets = [round(-0.95 + 0.1 * i, 2) for i in range(20)]
        replies = await asyncio.gather(*(
            get_json(http, GOTO, s="burst", input=json.dumps({"posRef": target})) for target in targets))
        target_of = {reply["id"]: target for reply, target in zip(replies, targets, strict=True)}
        assert len(target_of) == 20

        # The robot has one motion: genom_state lists exactly one activity.
        state = (await get_json(http, "/module/demo/read/genom_state"))["genom_state"]
        activities = [a for task in state["task"] for a in task["activity"]]
        assert len(activities) == 1 and activities[0]["name"] == "GotoPosition"
        survivor = f"demo::{activities[0]['id']}"

        statuses = {rid: await get_json(http, f"/module/demo/status/{rid}") for rid in target_of}
        assert [rid for rid, status in statuses.items() if status["status"] == "sent"] == [survivor]
        assert all(status == {"id": rid, "status": "error", "exception": INTERRUPTED}
                   for rid, status in statuses.items() if rid != survivor)

        # It ends alone, at its own target.
        ended = await get_json(http, f"/module/demo/wait/{survivor}")
        assert ended == {"id": survivor, "status": "done", "output": {}}
        mobile = (await get_json(http, "/module/demo/read/Mobile"))["Mobile"]
        assert mobile == {"position": target_of[survivor], "speed": 0.0}

        # Each request of the burst ended exactly once on the session's stream. A function sent
        # afterwards marks the end of what the burst can have produced.
        marker = (await get_json(http, "/module/demo/send/GetSpeed", s="burst"))["id"]
        finals: Counter[str] = Counter()
        while True:
            name, data = await stream.next_event()
            event = json.loads(data or "")
            assert name == "request"
            if event["id"] == marker:
                break
            if event["status"] != "sent":
                finals[event["id"]] += 1
        assert finals == Counter(target_of.keys())
    finally:
        stream.close()
