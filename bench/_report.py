"""Render benchmark results as the Markdown tables of docs/benchmarks.md."""

from __future__ import annotations

import functools
from typing import Any

HEAD = """# Benchmarks

Measured with `./run bench` on {cpus} CPUs, Python {python}, {date}{quick}. The gateway runs in its own
process with simulated components at real time; clients are Python (asyncio). Every figure is a median
(p99 where said) of repeated runs in one session, and every target is a ratio to what the same machine
does in the same run, because these machines are shared and noisy. `bench/results/latest.json` holds
everything. A target that is missed says **MISSED**.

This page is written by the benchmarks; do not edit it. A section can be measured again on its own:
`./run bench --only port_read` (or `memory`, `load`, `profile`, ... several at once), which keeps the other
sections' figures from `bench/results/latest.json` (each section says when it was measured);
`./run bench --render` rewrites the page from that file. `./run bench --quick` checks that every benchmark
works, in under a minute (its figures are not for the record). `AIOGENOMIX_BENCH_BASELINE=DIR` also measures
another checkout's gateway (`DIR/aiogenomix/gateway` ... as links) beside this one, in the same blocks; the
results name it by its commit (`git describe` of that checkout).

"""


def _figure(results: dict[str, Any], label: str) -> str:
    """A profiled function's ms per call, as text ("?" when the profile was not run)."""
    found = results.get("profile", {}).get("functions", {}).get(label)
    return f"{found['ms_per_call']:.2f} ms" if found else "?"


def _wake(results: dict[str, Any]) -> str:
    """What a pause before a read costs the plain-socket floor itself (section 1's fresh and back-to-back floors)."""
    window = results.get("port_read", {}).get("windows", {}).get("500", {})
    if "floor_fresh" not in window:
        return "see section 1's floors"
    return (f"the floor itself takes {window['floor_fresh']['median']:.2f} ms for the 500 ms window's bytes after a "
            f"pause against {window['floor']['median']:.2f} ms back to back, and the gateway, whose code path is "
            "longer, pays that more, with its simulated capture running between the reads")


def _analysis(results: dict[str, Any]) -> str:
    """Where the time goes: the profile's table, and what it and the figures above say."""
    from .profile import render as profile_table

    load = results.get("load", {})
    cpu = (f"{load['gateway_cpu_us_per_request']:.0f} µs of CPU per request against "
           f"{load['bare_cpu_us_per_request']:.0f} µs for bare aiohttp (ratio "
           f"{load['bare_cpu_us_per_request'] / load['gateway_cpu_us_per_request']:.2f})"
           if "gateway_cpu_us_per_request" in load else "its CPU per request (run `--only load`)")
    runtime = f"{load['runtime_send_us']:.0f} µs" if "runtime_send_us" in load else "a few µs"
    f = functools.partial(_figure, results)
    lines = ["## Where the time goes (profiles behind the figures above)", ""]
    if "profile" in results:
        lines.append(_dated(profile_table(results["profile"]), results["profile"].get("measured")))
    lines += [
        "* **How a port read works.** Each captured chunk is a read-only array wrapped in a `Chunk` that keeps its "
        "JSON text once made, its size and its bytes (`components/core/_chunked.py`); a publication holds "
        "references to its chunks. A read encodes the small struct with orjson, leaving a mark where each sample "
        "array goes, and splices in the chunks' texts (`gateway/_pieces.py`); the binary form lists the chunks' "
        "memory. Nothing is joined: the HTTP head and every piece go to the socket in one `writev` "
        "(`gateway/_gather.py`), and what the socket does not take goes to the transport. A body is kept per "
        "publication and form, so readers of one publication share it, and for each form read during a "
        "publication the next publication's body is made as soon as it is published (`gateway/_read_bodies.py`): "
        "a client polling at the port's rate finds it ready. Every request is read once, by aiohttp's parser "
        "(`gateway/_connection.py`, decision 37); a plain read (a `GET /module/M/read/P` with at most `format` "
        "and `since`, that the door admits as a program's) is answered by the server's handler ahead of the routes "
        "when the socket has nothing left to send (`gateway/_fast_reads.py`), without aiohttp's routing, "
        "middleware and response object. Every other request, and every read the door refuses or the routes "
        "answer with an error, is passed to aiohttp. The bytes are those orjson gives for the joined arrays, and "
        "those the route gives (`tests/gateway/test_port_pieces.py`, `test_fast_reads.py`); a window that turns "
        "over during a reply does not tear it.",
        "* **A read of a new publication** (the profile above): aiohttp reads every request's head "
        f"({f('aiohttp: a request' + chr(39) + 's bytes received and parsed (every request)')} per call under the "
        "profiler) and hands it to the server's handler "
        f"({f('the server' + chr(39) + 's handler: a plain read answered, or the routes')}), of which the "
        f"door {f('the door' + chr(39) + 's decision')}, the plain read "
        f"{f('a plain read answered ahead of the routes (all below but the write)')} (its body, found ready, "
        f"{f('the read' + chr(39) + 's body (made ahead for a polled form: found ready)')}) and the `writev` "
        f"{f('the gathered write (writev: the kernel' + chr(39) + 's copy)')}: the kernel's copy of the bytes, "
        "what the floor pays too. Each body made ahead took "
        f"{f('a body made ahead, when the publication came')} when its publication came: the struct "
        f"{f('the publication' + chr(39) + 's struct with chunked arrays')}, a JSON body "
        f"{f('build a JSON body (splice the chunks' + chr(39) + ' texts)')} (a new chunk's text is made once, by "
        f"its first reader), a binary one {f('build a binary body (list the chunks' + chr(39) + ' memory)')}. "
        "For comparison, `/version` through aiohttp's routes (a session named: a plain one is answered ahead of "
        "them): "
        f"{f('the guard, route and handler (/version)')} per request, of which its handler "
        f"{f('the /version handler')}. Each fresh read also pays waking both processes after a pause: "
        f"{_wake(results)}.",
        "* **Small windows (500 and 1000 ms).** The floor moves 0.18–0.87 MB in a few tenths of a millisecond, so "
        "any fixed cost of a request shows in their ratios. A plain HTTP read now costs little beyond parsing its "
        "request and the write; the ratios move from block to block with the machine's load (see the spreads).",
        "* **The dedicated socket (2014).** Its reply is copied once from the window's chunks into a buffer of its "
        "own (Python 3.11's transport would copy the part a socket does not take anyway, and since 3.12 a "
        "transport keeps the buffer it is handed), and readers of one publication share it; a request line goes "
        "through a Python line parser. The floor writes a ready buffer: the copy of a new publication and the "
        "parser are the difference, and the ratio moves most with the machine's load.",
        f"* **Load (50 clients).** The gateway spends {cpu}. Both servers spend most of a request in aiohttp "
        "(on Python 3.11 it also starts a task per request, which both pay); both read each request once, with "
        "aiohttp's parser. A plain send (a `GET` of a service with plain parameters, that the door admits as "
        "a program's) is answered by the server's request handler ahead of the routes, as plain reads are "
        "(`gateway/_fast_sends.py`, decision 41): the door (Host and Origin, one dictionary look-up for a Host "
        "seen before; the token; the query's parameter names, none here), the component runtime's request "
        f"({runtime} a `send` of `GetSpeed` in the runtime alone, measured in the benchmark's own process) and "
        "one write of a head made from a template, without aiohttp's router (which tries the routes under "
        "`/module` one regular expression after another), its two middleware layers and its `Response`. "
        "The throughput ratio also depends on how the two cores are shared with wrk and the rest of the "
        "machine: the CPU ratio is the steadier figure.",
        "* **Instructions per request.** On Python 3.11 aiohttp answers each request in a task of its own, "
        "started at the event loop's next turn, and wakes its connection's request loop before and after it: "
        "three turns of the loop a request (two on Python 3.12, where aiohttp starts the task eagerly), with a "
        "`Request` and a writer made for each. d5f1c87's connection answered a plain read with a reader of its "
        "own, in the turn its bytes came: that is most of what a plain read costs beyond d5f1c87's, the price "
        "of one parser (decision 47). Every JSON or text reply is written whole, its head made as aiohttp makes "
        "it, without aiohttp's header preparation (`gateway/_replies.py`), and plain GETs of `/` and `/version` "
        "are answered ahead of the routes by the routes' own functions (`gateway/_fast_answers.py`). A routed "
        "module description pays the router and the guard, but no longer its making: an instance describes "
        "itself once and its `/info` body is encoded once (`gateway/_info_bodies.py`; it was more than two "
        "thirds of the count).",
        "* **Memory.** At start the gateway imports only what serving needs (components are imported when first "
        "loaded); the figure with every component loaded is dominated by the simulators (MuJoCo for `world`, "
        "`pr2` and `morse_kemar`). A session costs about a kilobyte and sessions are bounded (`--max-sessions`); "
        "an uncleaned request a few hundred bytes until its session ends.",
        ""]
    return "\n".join(lines)


def _ms(value: float) -> str:
    return f"{value:.2f}"


def render(machine: dict[str, Any], results: dict[str, Any]) -> str:
    """The whole Markdown page."""
    from .budgets import render as budgets_section
    from .fuzz_memory import render as fuzz_memory_section
    from .instructions import render as instructions_section
    from .localisation import render as localisation_section
    from .record import render as record_section
    from .remote import render as remote_section
    from .rooms import render as rooms_section
    from .scale import render as scale_section
    from .sessions import render as sessions_section
    from .sse_clients import render as sse_section
    from .storm import render as storm_section
    from .viewers import render as viewers_section
    from .world import render as world_section

    facts = {k: v for k, v in machine.items() if k != "quick"}
    out = [HEAD.format(quick=" (quick runs)" if machine.get("quick") else "", **facts)]
    sections = [("port_read", _port_read), ("service", _service), ("fanout", _fanout), ("load", _load),
                ("soak", _soak), ("memory", _memory), ("world", world_section), ("remote", remote_section),
                ("scale", scale_section),
                ("sse_clients", sse_section), ("sessions", sessions_section), ("storm", storm_section),
                ("fuzz_memory", fuzz_memory_section),
                ("budgets", budgets_section), ("viewers", viewers_section),
                ("record", record_section), ("instructions", instructions_section),
                ("localisation", localisation_section), ("rooms", rooms_section)]
    for name, section in sections:
        if name in results:
            out.append(_dated(section(results[name]), results[name].get("measured")))
    out.append(_analysis(results))
    return "\n".join(out)


def _dated(text: str, measured: dict[str, Any] | None) -> str:
    """*text* with the date of its measurement under its title (sections can be measured on their own)."""
    if not measured:
        return text
    title, _, rest = text.partition("\n")
    quick = ", a quick run" if measured.get("quick") else ""
    return f"{title}\n\n*Measured {measured['date']}, Python {measured['python']}{quick}.*\n{rest}"


_LABELS = {
    "socket": "dedicated socket, request to last byte", "binary": "binary HTTP, request to last byte",
    "json": "genomix JSON, request to last byte", "binary_fresh": "binary HTTP, each read a new publication",
    "json_fresh": "genomix JSON, each read a new publication",
    "binary_before": "before: binary HTTP, request to last byte",
    "json_before": "before: genomix JSON, request to last byte",
}


def _ratio_rows(where: str, paths: dict[str, Any], targets: dict[str, float]) -> list[str]:
    rows = []
    for name, label in _LABELS.items():
        if name not in paths:
            continue
        p, floor = paths[name], paths[paths[name]["floor"]]
        target = targets[name.removesuffix("_fresh").removesuffix("_before")]
        verdict = "met" if p["ratio_to_floor"] <= target else "**MISSED**"
        if name.endswith("_before"):
            verdict = "(reference)"
        rows.append(f"| {where} | {label} | {p['bytes']} | {_ms(floor['median'])} | {_ms(p['median'])} "
                    f"({_ms(p['p10'])}–{_ms(p['p90'])}) | **{p['ratio_to_floor']:.2f}** | "
                    f"{p['ratio_min']:.2f}–{p['ratio_max']:.2f} | ≤ {target}× {verdict} |")
    return rows


_STRICT_LABELS = {"socket": "dedicated socket", "binary": "binary HTTP", "binary_before": "before: binary HTTP"}


def _strict_rows(r: dict[str, Any]) -> list[str]:
    """The table of the paths against the strict floor (absent from results measured before it existed)."""
    places = [(f"{window} ms", paths) for window, paths in r["windows"].items()]
    places += [("bass 4000 ms", r["bass"])] if "bass" in r else []
    if not all("strict" in paths for _, paths in places):
        return []
    targets = r.get("strict_targets", {})
    lines = ["", "Against the strict floor: the same bytes answered by one blocking `sendall` of a buffer made "
             "beforehand, from a thread per connection (no event loop, no copy); the targets apply to the 4000 ms "
             "windows.", "",
             "| port | path | strict floor median ms | × strict floor | block spread | target |",
             "|---|---|---|---|---|---|"]
    for where, paths in places:
        for name, label in _STRICT_LABELS.items():
            if name not in paths["strict"]:
                continue
            ratio = paths["strict"][name]
            target = targets.get(name) if where.endswith("4000 ms") else None
            verdict = ("(reference)" if target is None else
                       f"≤ {target}× " + ("met" if ratio["ratio"] <= target else "**MISSED**"))
            lines.append(f"| {where} | {label} | {_ms(ratio['floor_median'] * 1e3)} | **{ratio['ratio']:.2f}** | "
                         f"{ratio['ratio_min']:.2f}–{ratio['ratio_max']:.2f} | {verdict} |")
    return lines


def _port_read(r: dict[str, Any]) -> str:
    lines = ["## 1. Reading the audio window", "",
             f"Stereo int32 at 44.1 kHz in 50 ms chunks: `{r.get('module', 'capture')}`'s Port (with a head position "
             "per chunk) for three window lengths, and `bass`'s frame-indexed Audio port (4000 ms). Each path is "
             "compared with the same number of bytes served by a plain asyncio socket and received the same way "
             "(into a new buffer, no parsing), timed from request to last byte by a raw reader (no client library). "
             "The paths take turns "
             "in blocks of reads; a ratio is the median over blocks of (path median ÷ floor median in that block), "
             "and the spread is the lowest and highest block ratio. *Each read a new publication*: the reader waits "
             "one chunk period (untimed) before each read, and so does its floor, so no read shares the reply of "
             "a publication already served (what a client polling at the port's rate gets).", "",
             *([f"*Before*: the gateway of {r['baseline']}, run beside this one and read in the same blocks.", ""]
               if r.get("baseline") else []),
             "| port | path | bytes | floor median ms | median ms (p10–p90) | × floor | block spread | target |",
             "|---|---|---|---|---|---|---|---|"]
    for window, paths in r["windows"].items():
        lines += _ratio_rows(f"{window} ms", paths, r["targets"])
    if "bass" in r:
        lines += _ratio_rows("bass 4000 ms", r["bass"], r["targets"])
    lines += _strict_rows(r)
    lines += ["", "For reference (not targets): the generated Python client, request to numpy arrays, and what "
              "parsing the JSON reply with `orjson.loads` costs a client. The seed (MATLAB) took 450 ms for 4000 ms "
              "through genomix JSON (Table 5.2) and 28 / 32 / 86 ms through the dedicated socket (Table 6.2).", "",
              "| window | Python client, socket | Python client, binary | Python client, JSON "
              "| incremental (1 new chunk) "
              "| orjson.loads of the JSON reply | seed (MATLAB), dedicated socket |",
              "|---|---|---|---|---|---|---|"]
    for window, paths in r["windows"].items():
        seed = r["seed_ms"]["socket"].get(window, "")
        lines.append(f"| {window} ms | {_ms(paths['client_socket']['median'])} "
                     f"| {_ms(paths['client_binary']['median'])} | {_ms(paths['client_json']['median'])} "
                     f"| {_ms(paths['client_incremental']['median'])} | {_ms(paths['orjson_parse_ms'])} | {seed} |")
    if "bass" in r:
        lines.append(f"| bass 4000 ms | {_ms(r['bass']['client_socket']['median'])} | | | | "
                     f"{_ms(r['bass']['orjson_parse_ms'])} | |")
    missed = [k for k, v in r["verdicts"].items() if v != "met"]
    lines += ["", f"Verdicts: {len(r['verdicts']) - len(missed)} of {len(r['verdicts'])} ratios met"
              + (f"; **MISSED**: {', '.join(missed)}." if missed else "."), ""]
    return "\n".join(lines)


def _memory(r: dict[str, Any]) -> str:
    return "\n".join([
        "## 6. Memory", "",
        "Resident size of the gateway process (the benchmark gateway: the probe component registered, nothing "
        "loaded), then with demo and ten more components loaded (every installed one; the world's render process "
        "counted in), and the cost of a session "
        f"({r['sessions']} started) and of a request nobody cleans ({r['requests']} `send`s of a function).", "",
        "| figure | value | target |", "|---|---|---|",
        f"| RSS at start | {r['rss_start_mb']:.1f} MB | ≤ {r['target_start_mb']:.0f} MB |",
        f"| RSS with {len(r['components']) + 1} components loaded | {r['rss_loaded_mb']:.1f} MB | |",
        f"| per session | {r['per_session_bytes'] / 1024:.2f} kB | ≤ {r['target_session_kb']:.0f} kB (bounded: "
        "at most --max-sessions) |",
        f"| per uncleaned request | {r['per_request_bytes']:.0f} B | |",
        "", f"**{r['verdict']}**" + (f" (could not load: {', '.join(r['failed'])})" if r["failed"] else ""), ""])


def _service(r: dict[str, Any]) -> str:
    c, b, a = r["client_call"], r["bare_aiohttp_get"], r["activity_done_event"]
    return "\n".join([
        "## 2. Service round trip", "",
        "| what | median ms | p99 ms |", "|---|---|---|",
        f"| generated client, blocking function call (send, event, clean) | {_ms(c['median'])} | {_ms(c['p99'])} |",
        f"| bare aiohttp GET round trip (floor) | {_ms(b['median'])} | {_ms(b['p99'])} |",
        f"| activity `done` event: end on the server → client receipt | {_ms(a['median'])} | {_ms(a['p99'])} |",
        f"| KEMAR `GetPosition`: client → gateway → driver → virtual CAN → simulated drive → back "
        f"| {_ms(r['kemar_get_position']['median'])} | {_ms(r['kemar_get_position']['p99'])} |",
        "",
        f"The seed reports {r['seed_drive_reply_ms']} ms for the real Elmo drive alone to answer a position "
        "query; here the drive is simulated, so the figure is the software path a real reply would add to.",
        "",
        f"Ratio {r['ratio']:.2f}× the bare round trip (target ≤ {r['target_ratio']}×): **{r['verdict']}**. "
        f"For comparison, rosbridge + roslibpy publish a {r['rosbridge_service_median_ms']} ms median service call.",
        ""])


def _fanout(r: dict[str, Any]) -> str:
    w, s = r["watch"], r["sessions"]
    return "\n".join([
        "## 3. Event fan-out with 100 readers", "",
        "Latency from publication on the server to receipt by a client (same monotonic clock).", "",
        "| what | events | median ms | p99 ms |", "|---|---|---|---|",
        f"| 100 readers watching a 20 Hz port (`/watch`) | {w['n']} | {_ms(w['median'])} | {_ms(w['p99'])} |",
        f"| `request` events, 100 sessions listening, requests running | {s['n']} | {_ms(s['median'])} "
        f"| {_ms(s['p99'])} |",
        "", f"Target p99 ≤ {r['target_p99_ms']} ms: **{r['verdict']}**.", ""])


def _load(r: dict[str, Any]) -> str:
    if "skipped" in r:
        return f"## 4. Load\n\nSkipped: {r['skipped']}\n"
    return "\n".join([
        "## 4. Load: 50 concurrent clients", "",
        "wrk, 50 connections, calling `send` of a function service (its reply is already `done`), against a "
        "bare aiohttp handler returning the same JSON; alternating rounds.", "",
        "| server | requests/s (median of rounds) |", "|---|---|",
        f"| aiogenomix gateway | {r['gateway_requests_per_s']:.0f} |",
        f"| bare aiohttp | {r['bare_requests_per_s']:.0f} |",
        *([] if "baseline" not in r else [
            f"| before: the gateway of {r['baseline']} | {r['baseline_requests_per_s']:.0f} |"]),
        "",
        f"Ratio {r['ratio']:.3f}, median of alternating rounds (rounds: {', '.join(f'{x:.2f}' for x in r['ratios'])}; "
        f"spread {min(r['ratios']):.2f}–{max(r['ratios']):.2f}; target ≥ "
        f"{r['target_ratio']}), {r['errors']} errors in {r['gateway_requests']} requests: **{r['verdict']}**.",
        *([] if "baseline" not in r else [
            "", f"Before ({r['baseline']}), in the same rounds: ratio {r['baseline_ratio']:.3f} (rounds: "
            f"{', '.join(f'{x:.2f}' for x in r['baseline_ratios'])})."]),
        *([] if "gateway_cpu_us_per_request" not in r else [
            "", f"CPU time per request (from /proc, the server's own, whatever else the machine runs): gateway "
            f"{r['gateway_cpu_us_per_request']:.0f} µs, bare aiohttp {r['bare_cpu_us_per_request']:.0f} µs "
            + (f"(gateway ÷ bare aiohttp {r['cpu_ratio']:.2f}, median of the rounds' ratios; target ≤ "
               f"{r['target_cpu_ratio']})" if "cpu_ratio" in r else
               f"(ratio {r['bare_cpu_us_per_request'] / r['gateway_cpu_us_per_request']:.2f})")
            + ("." if "baseline" not in r else f", before {r['baseline_cpu_us_per_request']:.0f} µs"
               + (f" ({r['baseline_cpu_ratio']:.2f} of bare aiohttp's)." if "baseline_cpu_ratio" in r else "."))]),
        *([] if "note" not in r else ["", r["note"]]),
        ""])


def _soak(r: dict[str, Any]) -> str:
    return "\n".join([
        "## 5. Streaming soak", "",
        f"{r['seconds']:.0f} s of real time at 44.1 kHz / 50 ms: 8 dedicated-socket readers and 8 incremental "
        "HTTP readers, each polling every 100 ms.", "",
        "| figure | value | target |", "|---|---|---|",
        f"| chunks lost | {r['chunks_lost']} | 0 |",
        f"| chunks per reader (expected ≈ {r['chunks_expected_per_reader']:.0f}) | "
        f"{min(r['chunks_per_socket_reader'] + r['chunks_per_http_reader'])}–"
        f"{max(r['chunks_per_socket_reader'] + r['chunks_per_http_reader'])} | |",
        f"| gateway CPU, share of one core | {100 * r['gateway_cpu_share_of_one_core']:.1f} % | ≤ 15 % |",
        f"| gateway RSS start → end | {r['rss_start_mb']:.1f} → {r['rss_end_mb']:.1f} MB "
        f"({100 * r['rss_growth']:+.1f} %) | ≤ +10 % |",
        "", f"**{r['verdict']}**", ""])
