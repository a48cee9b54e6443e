"""Acceptance 1 and 2: the seed's Figure 4.3 session with generated functions, sync, async, and in a running loop."""

from __future__ import annotations

import asyncio
import inspect
import pydoc
import re

from aiogenomix.clients import AsyncRequest, Record, Request, Status, aconnect, connect


def figure_4_3_session(url: str) -> None:
    """``genomix::connect; load demo; GotoPosition 0.5; GotoPosition 1 &; ::demo::0; Mobile``, in Python."""
    with connect(url) as genomix1:
        demo = genomix1.load("demo")
        assert demo.GotoPosition(0.5) is None                 # blocks until the robot is there
        assert demo.Mobile().position == 0.5

        request = demo.GotoPosition(1, ack=True)              # Tcl's `&`, the bridge's 'nonblocking'
        assert isinstance(request, Request)
        assert request.status == "sent" and request.status is Status.sent    # "request demo::0 in progress"
        assert request.id.startswith("demo::")
        assert request.wait(timeout=30)
        assert request.status == "done"
        assert request.result() is None                       # GMB_demo_0() -> []

        mobile = demo.Mobile()                                # Mobile {position 1 speed 0}
        assert mobile == {"position": 1.0, "speed": 0.0}
        assert isinstance(mobile, Record)
        assert demo.Mobile(raw=True) == {"Mobile": {"position": 1.0, "speed": 0.0}}


def test_figure_4_3_sync(threaded_gateway_url: str) -> None:
    figure_4_3_session(threaded_gateway_url)


async def test_figure_4_3_inside_a_running_event_loop(threaded_gateway_url: str) -> None:
    # Jupyter's main thread runs an event loop: the sync client must work there, unchanged.
    asyncio.get_running_loop()
    figure_4_3_session(threaded_gateway_url)


async def test_figure_4_3_async(gateway_url: str) -> None:
    async with aconnect(gateway_url) as genomix1:
        demo = await genomix1.load("demo")
        assert await demo.GotoPosition(0.5) is None
        assert (await demo.Mobile()).position == 0.5

        request = await demo.GotoPosition(1, ack=True)
        assert isinstance(request, AsyncRequest)
        assert request.status == "sent"
        assert await request is None
        assert request.status == "done"

        assert await demo.Mobile() == {"position": 1.0, "speed": 0.0}


async def test_signature_help_and_dir(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        info = demo.__info__
        signature = inspect.signature(demo.GotoPosition)
        param = signature.parameters["posRef"]
        assert list(signature.parameters)[0] == "posRef"
        assert param.default == 0.0 and param.annotation is float
        assert signature.parameters["ack"].kind is inspect.Parameter.KEYWORD_ONLY
        assert demo.GotoPosition.__name__ == "GotoPosition"
        assert inspect.iscoroutinefunction(demo.GotoPosition)

        doc = inspect.getdoc(demo.GotoPosition)
        assert doc is not None
        assert "Move the robot to an absolute position on the track." in doc
        assert "posRef (double, m): Goto position in m. Default: 0.0." in doc
        assert "TOO_FAR_AWAY" in doc and "overshoot" in doc
        assert "Interrupts:" in doc and "GotoPosition, MoveDistance" in doc

        speed = inspect.signature(demo.SetSpeed).parameters["speedRef"]
        assert speed.default == "::demo::SLOW"
        assert "SLOW" in str(speed.annotation) and "::demo::FAST" in str(speed.annotation)

        names = set(dir(demo))
        assert {s["name"] for s in info["services"]} <= names
        assert {p["name"] for p in info["ports"]} <= names
        assert "TOO_FAR_AWAY" in names
        assert not any(n.startswith("_") for n in names)
        assert "Move the robot" in (demo.__doc__ or "")


def test_help_renders_info_docs(threaded_gateway_url: str) -> None:
    with connect(threaded_gateway_url) as client:
        demo = client.load("demo")
        # Python 3.13's pydoc puts long signatures one parameter a line: compare them unwrapped
        # (and without the " | " margin of a class's members).
        def unwrapped(text: str) -> str:
            text = re.sub(r"^ \|", "", text, flags=re.MULTILINE)
            return re.sub(r"\(\s+", "(", re.sub(r",\s+", ", ", text))

        rendered = unwrapped(pydoc.render_doc(demo.GotoPosition, renderer=pydoc.plaintext))
        assert "GotoPosition(posRef: float = 0.0, *, ack: bool = False" in rendered
        assert "Goto position in m" in rendered
        assert inspect.signature(demo.Monitor).return_annotation is Record
        module_help = unwrapped(pydoc.render_doc(demo, renderer=pydoc.plaintext))
        assert "A virtual mobile robot on a line" in module_help
        assert "GotoPosition(posRef: float = 0.0" in module_help
        assert "Mobile(*, since: Optional[int] = None, raw: bool = False" in module_help


async def test_outputs_and_argument_forms(gateway_url: str) -> None:
    async with aconnect(gateway_url) as client:
        demo = await client.load("demo")
        watch = await demo.Monitor(0.25, ack=True)
        await demo.GotoPosition(0.5)
        state = await watch                                   # one output: returned directly
        assert isinstance(state, Record) and state.position >= 0.25
        assert watch.output == {"state": state}               # the handle keeps them all by name
        assert (await demo.genom_state()).task[0].name == "motion"

        assert await demo.GetSpeed() == "::demo::SLOW"
        await demo.SetSpeed("FAST")                           # positional, short enum name
        assert await demo.GetSpeed() == "::demo::FAST"
        await demo.SetSpeed({"speedRef": "::demo::MEDIUM"})   # one dict, full name
        assert await demo.GetSpeed() == "::demo::MEDIUM"
        await demo.SetSpeed(speedRef="SLOW")                  # keyword
        assert await demo.GetSpeed() == "::demo::SLOW"
        await demo.SetSpeed()                                 # missing: the /info default
        assert await demo.GetSpeed() == "::demo::SLOW"
