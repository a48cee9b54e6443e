"""Issue 14: property-based fuzzing of every endpoint and every service input of every component.

A gateway with every component loaded runs on a thread of its own; hypothesis
writes requests to it over a real socket: endpoints with odd names, ids,
sessions and query values, and service inputs drawn from each service's own
``/info`` description, mixed with the values that broke decoders before
(integers of thousands of digits, NaN, lone surrogates, deep nesting, wrong
types).  Over 10,000 requests per run, no reply may be a 5xx, no connection
may be dropped without a reply, and every error must be a documented JSON
body.  Meanwhile a witness session moves its own robot on the same gateway;
it must end exactly as it would have alone, and hear only its own events.

``HYPOTHESIS_PROFILE=explore`` draws new examples on each run; otherwise the
seed is fixed (``AIOGENOMIX_FUZZ_SEED``, by default the Python minor version),
so that a failure is reproducible.  ``AIOGENOMIX_FUZZ_EXAMPLES`` sets the
requests per family (1200 by default).
"""

from __future__ import annotations

import http.client
import json
import os
import socket
import sys
import threading
import urllib.parse
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from aiogenomix.gateway import GatewayConfig, serve_in_thread

COMPONENTS = ["demo", "countserver", "countclient", "kemar", "capture", "kemarcapture", "bass", "basc"]
WITNESS = "witness"
#: Requests per family of the tests below (six families; ./run test adds 300 a family on each other Python:
#: over 10,000 requests in all).
EXAMPLES = int(os.environ.get("AIOGENOMIX_FUZZ_EXAMPLES", "1200"))
#: A fixed seed makes a failure reproducible; it differs per Python, so each one tries other requests.
SEED = int(os.environ.get("AIOGENOMIX_FUZZ_SEED", str(sys.version_info.minor)))

# Reprs of 5000-digit inputs are long; hypothesis warns about them, which pytest would make errors.
# A family takes 10-20 s alone; a busy shared machine may take several times that.
pytestmark = [pytest.mark.filterwarnings("ignore::hypothesis.errors.HypothesisWarning"), pytest.mark.timeout(600)]

settings.register_profile("ci", deadline=None, database=None,
                          suppress_health_check=list(HealthCheck), max_examples=EXAMPLES)
settings.register_profile("explore", deadline=None, suppress_health_check=list(HealthCheck),
                          max_examples=EXAMPLES)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


class Gateway:
    """A blocking client of the fuzzed gateway, keeping one connection open like most clients do."""

    def __init__(self, url: str) -> None:
        parsed = urllib.parse.urlsplit(url)
        self.host, self.port = parsed.hostname or "127.0.0.1", parsed.port or 80
        self._connection: http.client.HTTPConnection | None = None
        self.count = 0

    def get(self, path: str, headers: dict[str, str] | None = None) -> tuple[int, bytes, str]:
        """Send one GET; return status, body and content type.  A dropped connection fails the test."""
        if self._connection is None:
            self._connection = http.client.HTTPConnection(self.host, self.port, timeout=30)
        try:
            self._connection.request("GET", path, headers=headers or {})
            reply = self._connection.getresponse()
            body = reply.read()
        except (OSError, http.client.HTTPException) as exc:
            self._connection.close()
            self._connection = None
            raise AssertionError(f"GET {path[:200]!r}: no reply ({exc!r})") from exc
        self.count += 1
        if reply.getheader("Connection", "").lower() == "close":
            self._connection.close()
            self._connection = None
        return reply.status, body, reply.getheader("Content-Type", "")

    def json(self, path: str) -> Any:
        status, body, _ = self.get(path)
        assert status == 200, (path, status, body[:300])
        return json.loads(body)

    def close(self) -> None:
        if self._connection is not None:
            self._connection.close()


def check(gateway: Gateway, path: str, headers: dict[str, str] | None = None) -> int:
    """Send *path*; no 5xx, and every error a documented JSON error body."""
    status, body, content_type = gateway.get(path, headers)
    assert status < 500, f"GET {path[:300]!r} -> {status}: {body[:500]!r}"
    if status >= 400:
        assert content_type.startswith("application/json"), (path[:300], status, content_type, body[:200])
        error = json.loads(body)
        assert isinstance(error.get("ex"), str) and error["ex"].startswith("::"), (path[:300], error)
        assert isinstance(error.get("message"), str) and error["message"], (path[:300], error)
    return status


def quote(text: str) -> str:
    """Percent-encode anything, lone surrogates and invalid UTF-8 included (as a browser would send bytes)."""
    return urllib.parse.quote(text.encode("utf-8", "surrogatepass"), safe="")


class Witness:
    """A session of its own moving its own robot back and forth while the fuzzer runs, listening to its events."""

    def __init__(self, gateway: Gateway, url: str) -> None:
        self.gateway = gateway
        status, body, _ = gateway.get(f"/session/start?s={WITNESS}")
        assert status == 200, body
        self.session = body.decode().strip().strip('"')
        self.events: list[str] = []
        self.moves: list[tuple[float, dict[str, Any], float]] = []   # (target, final status, position after)
        parsed = urllib.parse.urlsplit(url)
        self._stream = socket.create_connection((parsed.hostname, parsed.port), timeout=60)
        self._stream.sendall(f"GET /session/listen?s={self.session} HTTP/1.1\r\nHost: {parsed.netloc}\r\n\r\n"
                             .encode())
        self._reader = threading.Thread(target=self._read, name="witness events", daemon=True)
        self._reader.start()
        assert gateway.get(f"/load/demo?argv={quote('-i ' + WITNESS)}&s={self.session}")[0] == 200
        self._stop = threading.Event()
        self._mover = threading.Thread(target=self._move, name="witness moves", daemon=True)
        self._mover.start()

    def _read(self) -> None:
        buffer = b""
        try:
            while chunk := self._stream.recv(65536):
                buffer += chunk
                *blocks, buffer = buffer.split(b"\n\n")
                self.events.extend(b.decode() for b in blocks if b"event:" in b)
        except OSError:
            pass

    def _move(self) -> None:
        target = 0.3
        while not self._stop.is_set():
            sent = self.gateway.json(f"/module/{WITNESS}/send/GotoPosition?s={self.session}&input={target}")
            final = self.gateway.json(f"/module/{WITNESS}/wait/{sent['id']}?timeout=60")
            assert self.gateway.get(f"/module/{WITNESS}/clean/{sent['id']}")[0] == 200
            position = self.gateway.json(f"/module/{WITNESS}/read/Mobile")["Mobile"]["position"]
            self.moves.append((target, final, position))
            target = -target

    def finish(self) -> list[tuple[float, dict[str, Any], float]]:
        """Stop after the current move; return every move made."""
        self._stop.set()
        self._mover.join(120)
        self.gateway.close()
        self._stream.close()
        self._reader.join(10)
        return self.moves


@pytest.fixture
def no_leaks() -> Iterator[None]:
    """The gateway and what the fuzzer loads in it live for the whole module: leaks are checked at its end."""
    yield


@pytest.fixture(scope="module")
def fuzzed() -> Iterator[tuple[Gateway, dict[str, Any], Witness]]:
    config = GatewayConfig.of(port=0, time_scale=1.0, audio_socket_port=0)
    threads_before = set(threading.enumerate())
    with serve_in_thread(config) as url:
        gateway = Gateway(url)
        infos = {}
        for name in COMPONENTS:
            assert gateway.get(f"/load/{name}")[0] == 200
            infos[name] = gateway.json(f"/module/{name}/info")
        witness = Witness(Gateway(url), url)
        yield gateway, infos, witness
        moves = witness.finish()
        # Alone, each move ends done at its target, and its session hears its own events only.
        assert moves
        for target, final, position in moves:
            assert final["status"] == "done" and position == pytest.approx(target), (target, final, position)
        requests = [e for e in witness.events if "event: request" in e]
        assert len(requests) >= 2 * len(moves) - 1 and all(f'"{WITNESS}::' in e for e in requests), witness.events
        assert not [e for e in witness.events if "event: unload" in e]
        gateway.close()
        assert gateway.count > 0
    # Everything the fuzzer started (components' bus and device threads) ended with the gateway.
    left = [t for t in threading.enumerate() if t not in threads_before and t.is_alive()]
    for thread in left:
        thread.join(timeout=5)
    assert not [t.name for t in left if t.is_alive()], "the fuzzed gateway left threads running"


# -- values ---------------------------------------------------------------------------------------

class Raw(str):
    """JSON text sent as it is (numbers too long for Python's int-to-text limit to write)."""


#: Values that broke decoders before, and their relatives.
nasty = st.sampled_from([
    Raw("1" + "0" * 5000), Raw("-" + "9" * 4400), Raw("4" * 4000 + ".5"), Raw("1e99999"), 10**400, 2**64,
    -(2**63) - 1, float("nan"), float("inf"), 1e308, -1e-320,
    "\ud800", "\udfff", "a\u0000b", "\u202e", "", " ", "x" * 5000, [], {}, [[[[]]]], None, True, False,
    "::demo::FAST", "FAST", "SLOW", "::nope::X",
])

scalars = st.one_of(st.integers(), st.floats(allow_nan=True, allow_infinity=True), st.text(), st.booleans(),
                    st.none(), nasty)
json_values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=4)
                           | st.dictionaries(st.text(max_size=8), inner, max_size=4), max_leaves=12)


def deep(depth: int) -> str:
    return "[" * depth + "]" * depth


def encode_input(value: Any) -> str:
    """JSON as a client would write it (NaN, Infinity and huge numbers included: genom3 clients send them)."""
    if isinstance(value, Raw):
        return str(value)
    if isinstance(value, dict):
        return "{" + ",".join(f"{json.dumps(k, ensure_ascii=False)}:{encode_input(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ",".join(encode_input(v) for v in value) + "]"
    return json.dumps(value, allow_nan=True, ensure_ascii=False)


def value_for(type_: dict[str, Any]) -> st.SearchStrategy[Any]:
    """Values for an IDL type from /info: mostly of the type, often at its edges, sometimes anything."""
    kind = type_.get("kind")
    fitting: st.SearchStrategy[Any]
    if kind in ("short", "long", "long long", "octet", "unsigned short", "unsigned long", "unsigned long long"):
        fitting = st.one_of(st.integers(-3, 3), st.integers(-(2**70), 2**70))
    elif kind in ("float", "double"):
        fitting = st.floats(allow_nan=True, allow_infinity=True)
    elif kind in ("string", "char"):
        fitting = st.text(max_size=40)
    elif kind == "boolean":
        fitting = st.booleans()
    elif kind == "enum":
        values = type_.get("values", [])
        fitting = st.sampled_from(values + [v.rsplit("::", 1)[-1] for v in values]) if values else st.text()
    elif kind == "struct":
        members = type_.get("members", [])
        fitting = st.fixed_dictionaries({m["name"]: value_for(m["type"]) for m in members})
    elif kind in ("sequence", "array"):
        fitting = st.lists(value_for(type_.get("element", {})), max_size=5)
    elif kind == "optional":
        fitting = st.one_of(st.none(), value_for(type_.get("element", {})))
    else:
        fitting = json_values
    return st.one_of(fitting, fitting, fitting, nasty, json_values)


@st.composite
def service_requests(draw: st.DrawFn, infos: dict[str, Any]) -> str:
    module = draw(st.sampled_from(sorted(infos)))
    service = draw(st.sampled_from(infos[module]["services"]))
    # Leave the gateway's components loaded and running: the fuzzer targets inputs, not unloading.
    if service["name"] == "kill":
        service = infos[module]["services"][0]
    params = [p for p in service["parameters"] if p["dir"] in ("in", "inout")]
    chosen = draw(st.lists(st.sampled_from(params), unique_by=lambda p: p["name"])) if params else []
    inputs = {p["name"]: draw(value_for(p["type"])) for p in chosen}
    if draw(st.integers(0, 9)) == 0:
        inputs[draw(st.text(max_size=8))] = draw(json_values)        # an unknown parameter
    text = encode_input(inputs)
    shape = draw(st.integers(0, 19))
    if shape == 0:
        text = deep(draw(st.integers(500, 3000)))
    elif shape == 1:
        text = text[:draw(st.integers(0, max(0, len(text) - 1)))]    # truncated JSON
    elif shape == 2 and len(params) == 1:
        text = encode_input(draw(value_for(params[0]["type"])))     # a bare value, as Tcl users type it
    oneway = "&oneway=1" if draw(st.integers(0, 9)) == 0 else ""
    return f"/module/{module}/send/{quote(service['name'])}?s=fuzz&input={quote(text)}{oneway}"


names = st.one_of(st.sampled_from(COMPONENTS + ["", ".", "..", "genom_state", "Port", "Audio", "Mobile"]),
                  st.text(max_size=20).filter(lambda t: t != WITNESS))
ids = st.one_of(st.integers(-5, 50).map(str), st.sampled_from(["²", "٣", "1" * 5000, "demo::1", "::", "-0", " 1",
                                                               "0x1", "1e3", "nan"]), st.text(max_size=12))
query_values = st.one_of(st.sampled_from(["", "0", "-1", "nan", "inf", "-inf", "1e999", "binary", "json", "x" * 300]),
                         st.text(max_size=20))
verbs = st.sampled_from(["info", "send", "status", "wait", "abort", "clean", "read", "usage", "watch"])


@st.composite
def endpoint_requests(draw: st.DrawFn) -> str:
    kind = draw(st.integers(0, 5))
    module = draw(names)
    if module == WITNESS:
        module = "demo"
    if kind == 0:
        verb = draw(verbs)
        target = draw(ids if verb in ("status", "wait", "abort", "clean") else names)
        params = {"s": draw(st.one_of(st.just("fuzz"), st.text(max_size=10).filter(lambda t: t != WITNESS))),
                  "timeout": "0.01" if verb in ("wait",) else draw(query_values),
                  "since": draw(query_values), "format": draw(query_values), "name": draw(query_values)}
        if verb == "watch":
            return ""   # streams are exercised by their own tests; a fuzzer would hold them open
        keep = draw(st.lists(st.sampled_from(sorted(params)), unique=True))
        if verb == "wait":
            keep.append("timeout")
        query = "&".join(f"{k}={quote(params[k])}" for k in dict.fromkeys(keep))
        return f"/module/{quote(module)}/{verb}/{quote(target)}?{query}"
    if kind == 1:
        argv = draw(st.one_of(st.sampled_from(["-i", "-i x", "-i 1", "--bogus", "-i a b"]), st.text(max_size=20)))
        return f"/load/{quote(module)}?argv={quote(argv)}"
    if kind == 2:
        return f"/usage/{quote(module)}"
    if kind == 3:
        session = draw(st.text(max_size=140).filter(lambda t: t != WITNESS))
        verb = draw(st.sampled_from(["start", "stop"]))
        return f"/session/{verb}?s={quote(session)}"
    if kind == 4:
        return "/" + "/".join(quote(draw(st.text(max_size=10))) for _ in range(draw(st.integers(0, 5))))
    return draw(st.sampled_from(["/", "/version", "/console", "/modules", "/module/", "/module/demo",
                                 "/module/demo/send", "/session/listen", "/load/", "/unload/"]))


# -- the properties -------------------------------------------------------------------------------

def test_service_inputs_never_make_a_server_error(fuzzed: tuple[Gateway, dict[str, Any], Witness]) -> None:
    gateway, infos, _ = fuzzed

    @seed(SEED)
    @given(service_requests(infos))
    def property_(path: str) -> None:
        check(gateway, path)

    property_()


@pytest.mark.parametrize("family", range(4))
def test_endpoints_never_make_a_server_error(fuzzed: tuple[Gateway, dict[str, Any], Witness], family: int) -> None:
    gateway, _, _ = fuzzed

    @seed(SEED + family)
    @given(endpoint_requests())
    def property_(path: str) -> None:
        if path:
            check(gateway, path)

    property_()


def test_headers_never_make_a_server_error(fuzzed: tuple[Gateway, dict[str, Any], Witness]) -> None:
    gateway, _, _ = fuzzed
    header_text = st.text(st.characters(min_codepoint=32, max_codepoint=255, exclude_characters="\x7f"), max_size=40)

    @seed(SEED)
    @given(st.sampled_from(["Authorization", "Accept", "Origin", "Sec-Fetch-Site", "Cookie", "Last-Event-ID"]),
           header_text, st.sampled_from(["/", "/module/demo/read/Mobile", "/module/demo/info", "/console"]))
    def property_(name: str, value: str, path: str) -> None:
        check(gateway, path, {name: value.strip()})

    property_()
