"""Which host a load name designates, and whom a Zenoh session talks to (sans I/O: no session is opened)."""

from __future__ import annotations

import json
import pathlib

import pytest

from aiogenomix.components.core.runtime import AmbiguousModule, NoSuchModule, RemoteRefusal
from aiogenomix.remote._host_main import parse_args as parse_host_args
from aiogenomix.remote._host_main import token_warning
from aiogenomix.remote._offers import OfferBook, OfferedBefore, split_name
from aiogenomix.remote._session import ZenohSessionError, ZenohSettings
from aiogenomix.remote._wire import offer_token, parse_offer


def _offer(book: OfferBook, host: str, zid: str, instance: str) -> str:
    key = offer_token(host, zid, instance)
    offer = parse_offer(key)
    assert offer is not None and book.add(offer)
    book.set_facts(zid, {"endpoints": [f"tcp/{host}:7447"]})
    return key


def test_a_name_one_host_offers_is_that_host_s() -> None:
    book = OfferBook()
    _offer(book, "robot1", "aa", "demo")
    _offer(book, "robot2", "bb", "kemar")
    assert book.resolve("demo").host == "robot1"  # type: ignore[union-attr]
    assert book.resolve("demo@robot1").zid == "aa"  # type: ignore[union-attr]
    assert book.resolve("capture") is None  # nobody offers it, nobody did
    assert book.names() == ["demo", "kemar"]
    with pytest.raises(NoSuchModule, match="robot2 does not offer demo"):
        book.resolve("demo@robot2")
    with pytest.raises(NoSuchModule, match="not a load name"):
        book.resolve("demo@")


def test_a_name_two_hosts_offer_is_refused_naming_both_and_how_to_say_which() -> None:
    book = OfferBook()
    _offer(book, "robot1", "aa", "demo")
    _offer(book, "robot2", "bb", "demo")
    with pytest.raises(AmbiguousModule) as refused:
        book.resolve("demo")
    message = str(refused.value)
    assert "robot1 (tcp/robot1:7447)" in message and "robot2 (tcp/robot2:7447)" in message
    assert "load demo@robot1 or demo@robot2" in message
    assert book.resolve("demo@robot2").zid == "bb"  # type: ignore[union-attr]
    assert book.names() == ["demo"]


def test_two_hosts_with_one_id_are_refused_by_that_id_too() -> None:
    book = OfferBook()
    _offer(book, "robot1", "aa", "demo")
    _offer(book, "robot1", "cc", "demo")
    with pytest.raises(AmbiguousModule, match="2 component hosts call themselves robot1"):
        book.resolve("demo@robot1")


def test_a_name_offered_before_is_waited_for_not_given_up() -> None:
    book = OfferBook()
    key = _offer(book, "robot1", "aa", "kemar")
    assert book.remove(key) is not None
    assert book.facts("aa") == {}  # that run of the host is over
    with pytest.raises(OfferedBefore) as gone:
        book.resolve("kemar")
    assert gone.value.hosts == ["robot1"]
    with pytest.raises(OfferedBefore):
        book.resolve("kemar@robot1")
    _offer(book, "robot1", "dd", "kemar")  # the host restarted: a new session
    assert book.resolve("kemar").zid == "dd"  # type: ignore[union-attr]


def test_a_host_of_another_protocol_is_refused_and_listed() -> None:
    book = OfferBook()
    for key in ("aiogenomix/alive/demo", "aiogenomix/offer/3/robot9/ee/demo"):
        offer = parse_offer(key)
        assert offer is not None and not book.add(offer)
    with pytest.raises(RemoteRefusal) as refused:
        book.resolve("demo")
    assert refused.value.body["ex"] == "::genomix::remote_protocol"
    assert "protocol 1, 3" in refused.value.body["message"]
    assert [r["protocol"] for r in book.refused()] == [1, 3]
    assert book.names() == []


@pytest.mark.parametrize("name", ["de*mo", "a#b", "demo@**", "demo@rob/ot", "de$mo@robot1", "demo@robot 1", "*",
                                  "de mo", "demo@", "@robot1", "dé/mo"])
def test_a_load_name_that_cannot_be_a_key_is_no_module(name: str) -> None:
    # Each would be a Zenoh key expression (a wildcard, a separator) or no key at all: 404, never a 500.
    with pytest.raises(NoSuchModule, match="not a load name"):
        split_name(name)
    with pytest.raises(NoSuchModule):
        OfferBook().resolve(name)


@pytest.mark.parametrize("key", ["aiogenomix/offer/2//zz/demo", "aiogenomix/offer/2/robot1/aa", "aiogenomix/offer/2",
                                 "aiogenomix/offer/2/robot1/aa/demo/more", "aiogenomix/offer/2/robot1/not-hex/demo",
                                 "aiogenomix/offer/2/robot1/aa/de-mo", "aiogenomix/offer/2/rob%ot/aa/demo"])
def test_a_malformed_offer_of_our_protocol_is_no_offer(key: str) -> None:
    assert parse_offer(key) is None
    assert parse_offer("aiogenomix/offer/2/robot1/aa/demo") is not None


def test_hosts_show_where_each_runs_and_what_it_offers() -> None:
    book = OfferBook()
    _offer(book, "robot1", "aa", "demo")
    book.set_facts("aa", {"endpoints": ["tcp/10.0.0.1:7447"], "aiogenomix": "0.1.0",
                          "instances": {"demo": {"component": "demo", "version": "1.1"}}})
    [run] = book.hosts()
    assert run["host"] == "robot1" and run["zid"] == "aa" and run["protocol"] == 2
    assert run["endpoints"] == ["tcp/10.0.0.1:7447"]
    assert run["offers"] == {"demo": {"component": "demo", "version": "1.1"}}


def _values(settings: ZenohSettings) -> dict[str, object]:
    config = settings.config()
    return {key: json.loads(config.get_json(key)) for key in (
        "mode", "scouting/multicast/enabled", "scouting/gossip/enabled", "listen/endpoints", "connect/endpoints")}


def test_a_session_talks_to_the_endpoints_named_and_nobody_else() -> None:
    assert _values(ZenohSettings(connect=["tcp/10.0.0.1:7447"])) == {
        "mode": "peer", "scouting/multicast/enabled": False, "scouting/gossip/enabled": False,
        "listen/endpoints": [], "connect/endpoints": ["tcp/10.0.0.1:7447"]}
    listening = _values(ZenohSettings(listen=["tcp/10.0.0.1:7447"]))
    assert listening["listen/endpoints"] == ["tcp/10.0.0.1:7447"] and listening["connect/endpoints"] == []
    # Scouting is asked for by name: then Zenoh's defaults, which listen on every interface.
    scouting = _values(ZenohSettings(scout=True))
    assert scouting["scouting/multicast/enabled"] is True and scouting["scouting/gossip/enabled"] is True
    assert scouting["listen/endpoints"] == {"router": ["tcp/[::]:7447"], "peer": ["tcp/[::]:0"]}


def test_a_session_that_would_talk_to_nobody_is_refused() -> None:
    with pytest.raises(ZenohSessionError, match="would talk to nobody"):
        ZenohSettings().config()
    with pytest.raises(ZenohSessionError, match="is not a Zenoh endpoint"):
        ZenohSettings(connect=["tcp/robot"]).config()


def test_zenoh_s_own_file_is_kept_and_the_flags_replace_its_endpoints(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "zenoh.json5"
    path.write_text("""{
      // a lab's file: credentials, a router, its own listener
      mode: "client",
      connect: { endpoints: ["tcp/10.0.0.9:7447"] },
      transport: { auth: { usrpwd: { user: "gateway", password: "s3cret" } } },
    }""")
    values = _values(ZenohSettings(config_file=str(path)))
    assert values["mode"] == "client" and values["connect/endpoints"] == ["tcp/10.0.0.9:7447"]
    # What the file leaves at Zenoh's defaults is isolated.
    assert values["scouting/multicast/enabled"] is False and values["scouting/gossip/enabled"] is False
    config = ZenohSettings(config_file=str(path), connect=["tcp/10.0.0.1:7447"]).config()
    assert json.loads(config.get_json("connect/endpoints")) == ["tcp/10.0.0.1:7447"]
    assert json.loads(config.get_json("transport/auth/usrpwd"))["user"] == "gateway"
    (tmp_path / "scouting.json5").write_text('{scouting: {multicast: {enabled: true}}, listen: {endpoints: '
                                            '["tcp/10.0.0.1:0"]}}')
    kept = _values(ZenohSettings(config_file=str(tmp_path / "scouting.json5")))
    assert kept["scouting/multicast/enabled"] is True and kept["listen/endpoints"] == ["tcp/10.0.0.1:0"]
    # What the file says is kept even when it says Zenoh's default (gossip on, in peer mode).
    (tmp_path / "gossip.json5").write_text('{mode: "peer", scouting: {gossip: {enabled: true}}, connect: '
                                          '{endpoints: ["tcp/10.0.0.9:7447"]}}')
    gossip = _values(ZenohSettings(config_file=str(tmp_path / "gossip.json5")))
    assert gossip["scouting/gossip/enabled"] is True and gossip["scouting/multicast/enabled"] is False
    with pytest.raises(ZenohSessionError, match="cannot read the Zenoh configuration"):
        ZenohSettings(config_file=str(tmp_path / "missing.json5")).config()


def test_the_host_s_socket_token_comes_from_the_environment_and_the_command_line_is_warned_about(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AIOGENOMIX_TOKEN", "s3cret")
    assert parse_host_args(["demo", "--zenoh-listen", "tcp/127.0.0.1:7447"]).token == "s3cret"
    assert token_warning(["demo", "--zenoh-listen", "tcp/127.0.0.1:7447"]) is None
    for argv in (["demo", "--token", "s3cret"], ["demo", "--token=s3cret"]):
        warning = token_warning(argv)
        assert warning is not None and "AIOGENOMIX_TOKEN" in warning and "every user" in warning
