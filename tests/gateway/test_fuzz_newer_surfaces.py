"""Issue 24, acceptance 3: a fuzz of the newer surfaces gives no 5xx, no dropped connection, no traceback in the log.

A gateway on a thread of its own, with ``bass`` acquiring and serving its 2015 socket, ``basc``'s
in port connected to it, and ``capture`` capturing and serving its 2014 socket.  Hypothesis sends
it, over real sockets: fast reads with odd ``since`` and ``format`` values (numbers of any length,
Unicode digits, signs, exponents; plain, so that the connection's fast path answers them, or
percent-encoded for the routes), reads of the in port, load options with Unicode digits,
``abort_activity`` and ``abort`` of ids of any size, and the dedicated sockets' extremes (counts
and frame indices at and past int32 and int64, digits of other scripts).  Every HTTP answer is
below 500 and a documented JSON error when it is one; every socket request gets an ``ERROR`` line
or a whole reply before the connection closes; and the log holds no traceback and no ERROR line,
and few lines at all (those clients cause are rate-limited).

The seed is fixed (``AIOGENOMIX_FUZZ_SEED``, by default the Python minor version);
``AIOGENOMIX_FUZZ_NEWER_EXAMPLES`` sets the examples per family (200 by default, a few seconds in all;
60 on the other Pythons);
a longer run is the same test with a larger number.
"""

from __future__ import annotations

import json
import logging
import os
import re
import socket
import struct
import sys
import threading
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from aiogenomix.gateway import GatewayConfig, serve_in_thread
from tests.gateway.test_fuzz import Gateway, check, quote

#: Examples per family: 200 on the default Python, 60 on the others (AIOGENOMIX_HEAVY=0), whose seeds differ.
EXAMPLES = int(os.environ.get("AIOGENOMIX_FUZZ_NEWER_EXAMPLES",
                              "60" if os.environ.get("AIOGENOMIX_HEAVY") == "0" else "200"))
SEED = int(os.environ.get("AIOGENOMIX_FUZZ_SEED", str(sys.version_info.minor)))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None, suppress_health_check=list(HealthCheck))

pytestmark = [pytest.mark.filterwarnings("ignore::hypothesis.errors.HypothesisWarning"), pytest.mark.timeout(600)]

#: The frames of a capture chunk at its defaults (44100 Hz, 50 ms).
FPC = 2205


class _Records(logging.Handler):
    """Every log record of the gateway's thread while the module runs, and the ports its sockets open on."""

    def __init__(self) -> None:
        super().__init__(level=logging.DEBUG)
        self.records: list[logging.LogRecord] = []
        self.sockets: dict[str, int] = {}
        self.opened = threading.Condition()

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)
        if opened := re.match(r"(\w+): dedicated socket.* open on port (\d+)", record.getMessage()):
            with self.opened:
                self.sockets[opened.group(1)] = int(opened.group(2))
                self.opened.notify_all()


class Surfaces:
    """The fuzzed gateway: its HTTP client, its two dedicated sockets, and what it logged."""

    def __init__(self, gateway: Gateway, socket_2014: int, socket_2015: int, records: _Records) -> None:
        self.gateway, self.socket_2014, self.socket_2015, self.records = gateway, socket_2014, socket_2015, records
        self.socket_requests = 0


@pytest.fixture
def no_leaks() -> Iterator[None]:
    """The gateway lives for the whole module: its threads are checked at its end."""
    yield


@pytest.fixture(scope="module")
def surfaces() -> Iterator[Surfaces]:
    records = _Records()
    root = logging.getLogger()
    level = root.level
    root.addHandler(records)
    root.setLevel(logging.DEBUG)
    threads_before = set(threading.enumerate())
    try:
        with serve_in_thread(GatewayConfig.of(port=0, time_scale=1.0, audio_socket_port=0)) as url:
            gateway = Gateway(url)
            for name in ("demo", "capture", "bass", "basc"):
                assert gateway.get(f"/load/{name}")[0] == 200
            for path in ("/module/bass/send/Acquire?input=" + quote('{"device":"sim"}'),
                         "/module/capture/send/StartCapture?input=" + quote('{"device":"sim"}'),
                         "/module/basc/send/connect_port?input=" + quote('{"local":"Audio","remote":"bass/Audio"}'),
                         "/module/bass/send/DedicatedSocket", "/module/capture/send/DedicatedSocket"):
                assert gateway.get(path)[0] == 200
            with records.opened:
                assert records.opened.wait_for(lambda: len(records.sockets) == 2, timeout=60), records.sockets
            yield Surfaces(gateway, records.sockets["capture"], records.sockets["bass"], records)
            gateway.close()
    finally:
        root.removeHandler(records)
        root.setLevel(level)
    faults = [f"{r.levelname} {r.getMessage()}" for r in records.records
              if r.exc_info or r.levelno >= logging.ERROR or "Traceback" in r.getMessage()]
    assert not faults, faults
    # Lines clients cause are rate-limited: a few per kind, however many requests.
    assert len(records.records) < 200, [r.getMessage() for r in records.records][-20:]
    left = [t for t in threading.enumerate() if t not in threads_before and t.is_alive()]
    for thread in left:
        thread.join(timeout=5)
    assert not [t.name for t in left if t.is_alive()]


# -- values -------------------------------------------------------------------------------------

#: Digits of other scripts (superscript, Arabic-Indic, Devanagari, fullwidth...): str.isdigit() takes them.
OTHER_DIGITS = "²³¹٠٣٩०३९０９߃᠓"
numbers = st.one_of(
    st.integers(0, 2**70).map(str),
    st.integers(1, 6000).map(lambda n: "9" * n),
    st.sampled_from([str(2**31 - 1), str(2**31), str(2**32), str(2**63 - 1), str(2**63), str(2**64), "0" * 30 + "1",
                     "-1", "-0", "+1", "1e3", "1.5", "0x10", "nan", "inf", "", " 1", "1 "]),
    st.text(st.sampled_from("0123456789" + OTHER_DIGITS), min_size=1, max_size=25),
)


def plain(text: str) -> str:
    """*text* as a query value: plain when it can be (the fast path's form), else percent-encoded."""
    return text if re.fullmatch(r"[0-9a-z.\-]*", text) else quote(text)


# -- the properties -----------------------------------------------------------------------------

def test_reads_with_odd_queries_answer_without_a_server_error(surfaces: Surfaces) -> None:
    targets = ["bass/read/Audio", "capture/read/Port", "basc/read/Audio", "basc/read/Blocks", "demo/read/Mobile",
               "basc/read/genom_state", "bass/read/Nope"]

    @seed(SEED)
    @FUZZ
    @given(st.sampled_from(targets), numbers, st.sampled_from(["", "json", "binary", "xml", "²"]), st.booleans())
    def property_(target: str, since: str, fmt: str, encode: bool) -> None:
        value = quote(since) if encode else plain(since)
        query = f"since={value}" + (f"&format={plain(fmt)}" if fmt else "")
        status = check(surfaces.gateway, f"/module/{target}?{query}")
        assert status in (200, 400, 404), (target, since[:30], status)

    property_()


def test_load_options_with_other_digits_are_refused(surfaces: Surfaces) -> None:
    sizes = st.tuples(numbers, numbers).map(lambda wh: f"{wh[0]}x{wh[1]}")

    @seed(SEED)
    @FUZZ
    @given(sizes, numbers, st.sampled_from(OTHER_DIGITS), st.integers(0, 2))
    def property_(size: str, rate: str, digit: str, where: int) -> None:
        # At least one digit of another script, in the size or the rate: never a world that loads.
        if where == 0:
            size = digit + size
        elif where == 1:
            size = size + digit
        else:
            rate = rate + digit
        argv = f"-i w{digit} -size {size} -rate {rate}"
        status = check(surfaces.gateway, f"/load/world?argv={quote(argv)}")
        assert status == 400

    property_()


def test_aborts_of_any_id_are_answered(surfaces: Surfaces) -> None:
    @seed(SEED)
    @FUZZ
    @given(st.sampled_from(["demo", "bass", "basc", "capture"]), numbers, st.booleans())
    def property_(module: str, number: str, as_input: bool) -> None:
        if module in ("bass", "capture") and re.fullmatch(r"[+]?0*[01]", number.strip()):
            number = "7" + number.strip().lstrip("+")  # not the sockets the other properties read (ids 0 and 1)
        if as_input:
            text = '{"activity":' + number + "}"
            status, body, _ = surfaces.gateway.get(f"/module/{module}/send/abort_activity?input={quote(text)}")
            assert status in (200, 400), (number[:30], status, body[:200])
            if status == 200:
                reply = json.loads(body)
                # An id of no activity (none at all, a function's, this request's own) is no_such_activity;
                # one of an activity ends it (done).
                assert reply["status"] == "done" or reply["exception"]["ex"] == "::genom::no_such_activity", reply
        else:
            assert check(surfaces.gateway, f"/module/{module}/abort/{quote(number)}") in (200, 404)

    property_()


def _read_exactly(conn: socket.socket, size: int) -> bytes:
    data = bytearray()
    while len(data) < size:
        more = conn.recv(min(1 << 20, size - len(data)))
        assert more, f"the connection closed {size - len(data)} bytes short of the reply"
        data += more
    return bytes(data)


def test_the_2015_socket_answers_every_extreme_with_a_reply_or_an_error_line(surfaces: Surfaces) -> None:
    @seed(SEED)
    @FUZZ
    @given(numbers, numbers, st.sampled_from(["Read Port - N {n} - nfr {i}", "read port N={n} nfr={i}",
                                               "Read Port - nfr {i} - N {n}", "Read Port - N {n}"]))
    def property_(n: str, i: str, shape: str) -> None:
        line = shape.format(n=n, i=i).encode("utf-8")
        with socket.create_connection(("127.0.0.1", surfaces.socket_2015), timeout=30) as conn:
            conn.sendall(line + b"\n")
            head = _read_exactly(conn, 4)
            if head == b"ERRO":
                rest = conn.makefile("rb").readline()
                assert rest.startswith(b"R ") and rest.endswith(b"\n"), (line[:80], rest[:200])
                return
            head += _read_exactly(conn, 12)
            count, lost, next_frame = struct.unpack("<iiq", head)
            assert count >= 0 and lost >= 0 and next_frame >= 0, (line[:80], count, lost, next_frame)
            _read_exactly(conn, 8 * count)
            conn.sendall(b"Close\n")
            assert conn.recv(1) == b""
        surfaces.socket_requests += 1

    property_()


def test_the_2014_socket_answers_every_extreme_with_a_reply_or_an_error_line(surfaces: Surfaces) -> None:
    @seed(SEED)
    @FUZZ
    @given(numbers, st.sampled_from(["Read Port - Index {k}", "read port - index {k}", "Read Port - Index  {k}  "]))
    def property_(k: str, shape: str) -> None:
        line = shape.format(k=k).encode("utf-8")
        with socket.create_connection(("127.0.0.1", surfaces.socket_2014), timeout=30) as conn:
            conn.sendall(line + b"\n")
            head = _read_exactly(conn, 4)
            if head == b"ERRO":
                rest = conn.makefile("rb").readline()
                assert rest.startswith(b"R ") and rest.endswith(b"\n"), (line[:80], rest[:200])
                return
            (count,) = struct.unpack("<i", head)
            assert 0 <= count <= 20, (line[:80], count)
            (last,) = struct.unpack("<i", _read_exactly(conn, 8 * FPC * count + 4)[-4:])
            assert last >= count
        surfaces.socket_requests += 1

    property_()
