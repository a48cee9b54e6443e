"""The request endpoints one by one: status, wait, abort, clean, usage, a second instance, genom_state."""

from __future__ import annotations

import aiohttp


async def test_status_wait_abort_clean(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    async with http.get("/module/demo/send/GotoPosition", params={"input": '{"posRef":-1}'}) as reply:
        assert await reply.json() == {"id": "demo::0", "status": "sent"}
    for rq in ("demo::0", "0"):  # both id forms
        async with http.get(f"/module/demo/status/{rq}") as reply:
            assert await reply.json() == {"id": "demo::0", "status": "sent"}
    async with http.get("/module/demo/wait/0", params={"timeout": "0"}) as reply:
        assert (await reply.json())["status"] == "sent"  # the timeout answers the current status
    async with http.get("/module/demo/abort/demo::0") as reply:
        assert await reply.json() == {"id": "demo::0", "status": "error",
                                      "exception": {"ex": "::genom::interrupted", "detail": {"by": "abort"}}}
    async with http.get("/module/demo/read/Mobile") as reply:
        assert (await reply.json())["Mobile"]["speed"] == 0.0  # the stop path ran
    async with http.get("/module/demo/clean/0") as reply:
        assert reply.status == 200 and await reply.text() == ""
    async with http.get("/module/demo/status/0") as reply:
        assert reply.status == 404


async def test_usage_and_a_second_instance(http: aiohttp.ClientSession) -> None:
    async with http.get("/usage/demo") as reply:
        assert await reply.json() == [{"option": "-i NAME", "descr": "load the component under instance name NAME"}]
    async with http.get("/load/demo", params={"argv": "-i left"}) as reply:
        assert await reply.text() == "left"
    async with http.get("/load/demo", params={"argv": '["-i","right"]'}) as reply:
        assert await reply.text() == "right"
    async with http.get("/module/left/send/GotoPosition", params={"input": "0.3"}) as reply:
        assert (await reply.json())["id"] == "left::0"
    async with http.get("/module/left/wait/0") as reply:
        assert (await reply.json())["status"] == "done"
    async with http.get("/module/right/read/Mobile") as reply:
        assert (await reply.json())["Mobile"]["position"] == 0.0  # instances are independent
    async with http.get("/module/left/info") as reply:
        info = await reply.json()
    assert (info["name"], info["component"]) == ("left", "demo")
    async with http.get("/unload/left") as reply:
        assert await reply.text() == "left"
    async with http.get("/module/left/info") as reply:
        assert reply.status == 404


async def test_genom_state_shows_running_activities(http: aiohttp.ClientSession) -> None:
    await http.get("/load/countserver")
    await http.get("/module/countserver/send/CountStart")
    async with http.get("/module/countserver/read/genom_state") as reply:
        state = (await reply.json())["genom_state"]
    assert state["task"][0]["name"] == "count_task"
    assert state["task"][0]["activity"] == [{"id": 0, "name": "CountStart"}]
    assert state["version"] == "1.0" and state["date"]
