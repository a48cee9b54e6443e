"""The command line ``aiogenomix-record``: record a gateway's ports over HTTP, export a recording to WAV and CSV.

::

    aiogenomix-record URL INSTANCE/PORT... -o FILE.mcap [--duration S] [--session NAME] [--token TOKEN]
    aiogenomix-record export FILE.mcap -o DIR [--overwrite]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import signal
import sys
from collections.abc import Sequence
from typing import TextIO

from ..clients import GenomixError
from ..components.recording import RecordingCounts, RecordingError, WriteFailed, export_recording
from ._over_http import record_over_http

__all__ = ["main", "ProgressLine"]


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not value > 0:  # NaN too
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, not {text}")
    return value


def _record_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="aiogenomix-record",
        description="Record ports of an aiogenomix gateway into an MCAP file, over HTTP: every audio frame once "
                    "(read by index), other ports as they are published, and a session's request events. "
                    "Ctrl-C ends the recording cleanly. 'aiogenomix-record export FILE.mcap -o DIR' writes "
                    "its audio as WAV and its chunks and head azimuths as CSV.",
        epilog="example: aiogenomix-record localhost:8080 kemarcapture/Port kemarcapture/currentState "
               "-o session.mcap --duration 10")
    parser.add_argument("url", metavar="URL", help="the gateway, e.g. localhost:8080 or http://robot:8080")
    parser.add_argument("ports", metavar="INSTANCE/PORT", nargs="+", help="a port to record, e.g. kemarcapture/Port")
    parser.add_argument("-o", "--output", required=True, metavar="FILE.mcap",
                        help="the new recording (an existing file is never overwritten)")
    parser.add_argument("--duration", type=_positive, metavar="SECONDS",
                        help="record this long (default: until Ctrl-C)")
    parser.add_argument("--session", metavar="NAME",
                        help="also record the events of this genomix session (as one more listener: start "
                             "recording after the session's own client listens, or the events kept while "
                             "nobody listened come to the recording instead of to it)")
    parser.add_argument("--token", default=os.environ.get("AIOGENOMIX_TOKEN"),
                        help="the gateway's token (better given as $AIOGENOMIX_TOKEN)")
    parser.add_argument("--quiet", action="store_true", help="no progress line")
    return parser


def _export_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="aiogenomix-record export",
        description="Write a recording's audio as WAV (32-bit stereo at the capture rate, exactly the recorded "
                    "frames) and CSV (one row per chunk: frame index, head azimuth, times), each recorded "
                    "head state as CSV, and the recorded requests and events as events.csv, for MATLAB and Octave.")
    parser.add_argument("recording", metavar="FILE.mcap")
    parser.add_argument("-o", "--output", required=True, metavar="DIR", help="where to write (made if missing)")
    parser.add_argument("--overwrite", action="store_true", help="replace files of the same names in DIR")
    return parser


def _size(count: int) -> str:
    size = float(count)
    for unit in ("B", "kB", "MB"):
        if size < 1000:
            return f"{size:.0f} {unit}" if unit == "B" else f"{size:.1f} {unit}"
        size /= 1000
    return f"{size:.1f} GB"


class ProgressLine:
    """The progress of a recording, one line rewritten in place on a terminal (a line every 10 s otherwise).

    Args:
        stream: Where to write (stderr).
    """

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.tty = stream.isatty()
        self._last = -10.0

    @staticmethod
    def text(counts: RecordingCounts, elapsed: float) -> str:
        """``12.5 s  501 messages, 480 in the file (4.4 MB), 21 to come  0 frames lost  0 coalesced``.

        The file grows a compressed chunk at a time: the messages of the chunk being gathered (and
        those the writer has not taken yet) are said to come, so that a size standing still while
        messages are recorded does not read as nothing written.
        """
        written = counts.messages - counts.queued
        return (f"{elapsed:7.1f} s  {counts.messages} messages, {written} in the file ({_size(counts.bytes)}), "
                f"{counts.queued} to come  {counts.lost_frames} frames lost  {counts.coalesced} coalesced")

    def __call__(self, counts: RecordingCounts, elapsed: float) -> None:
        if self.tty:
            self.stream.write("\r" + self.text(counts, elapsed) + "\x1b[K")
            self.stream.flush()
        elif elapsed - self._last >= 10.0:
            self._last = elapsed
            self.stream.write(self.text(counts, elapsed) + "\n")
            self.stream.flush()

    def end(self) -> None:
        """End the progress line (on a terminal, the line redrawn in place is left as the last one)."""
        if self.tty:
            self.stream.write("\n")


async def _record(args: argparse.Namespace) -> int:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for signum in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(signum, stop.set)
    progress = None if args.quiet else ProgressLine(sys.stderr)
    try:
        path, counts, ended = await record_over_http(args.url, args.ports, args.output, duration=args.duration,
                                                     session=args.session, token=args.token, stop=stop,
                                                     progress=progress)
    except WriteFailed as exc:
        if progress is not None:
            progress.end()
        print(f"aiogenomix-record: the recording stopped: {exc.strerror or exc}", file=sys.stderr)
        return 1
    finally:
        for signum in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(signum)
    if progress is not None:
        progress.end()
    lost = f", {counts.lost_frames} audio frames lost" if counts.lost_frames else ", no audio frame lost"
    # What was made goes to stdout (the progress went to stderr): a script can take the path from it.
    print(f"aiogenomix-record: {path}: {_size(counts.bytes)}, {counts.messages} messages{lost}, "
          f"{counts.coalesced} publications coalesced ({ended})", flush=True)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``aiogenomix-record``; return the exit status (1 with one line saying why it failed)."""
    arguments = list(sys.argv[1:] if argv is None else argv)
    try:
        if arguments[:1] == ["export"]:
            args = _export_parser().parse_args(arguments[1:])
            def unfinished(said: str) -> None:
                print(f"aiogenomix-record: {said}", file=sys.stderr, flush=True)

            for exported in export_recording(args.recording, args.output, overwrite=args.overwrite,
                                             notice=unfinished):
                unit = "frames" if exported.path.suffix == ".wav" else "rows"
                print(f"{exported.path}: {exported.what} ({exported.rows} {unit})")
            return 0
        return asyncio.run(_record(_record_parser().parse_args(arguments)))
    except (RecordingError, GenomixError, OSError) as exc:
        print(f"aiogenomix-record: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
