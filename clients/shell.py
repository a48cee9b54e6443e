"""``aiogenomix-shell [HOST:PORT]``: an IPython session already connected to a gateway, with completion.

What eltclsh gave Tcl users, for Python: the loaded modules are names
(``demo``), their services complete on Tab (``demo.Go<Tab>``), so do keyword
arguments (``demo.GotoPosition(po<Tab>``) and enum values
(``demo.SetSpeed(speedRef="<Tab>``); ``demo.GotoPosition?`` shows the generated
documentation.  A call with ``ack=True`` returns at once; its end is printed
above the prompt when it comes, and ``requests()`` lists every such request
with its status.

An error of the gateway or of a component prints as one line
(``TOO_FAR_AWAY: overshoot=1.0 (GotoPosition, request demo::0)``), and so does
a mistake the client refuses before sending anything
(``TypeError: target: expected a number (double), got 'x' (MoveAbsolutePosition: nothing was sent)``):
any error raised by the client.  ``%tb`` prints the last one's full traceback.
Errors of the user's own code keep IPython's traceback.  Ctrl-C during a blocking call of an activity asks
the gateway to abort the request; a function, which genom cannot abort, runs to
its end, and the end is printed when it comes.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import contextlib
import functools
import inspect
import keyword
import os
import re
import signal
import sys
import threading
import traceback
from collections.abc import Callable, Sequence
from typing import Any

from ._ctrl_c import result_of
from ._errors import GenomixError, Interrupted, RemoteError, short_name
from ._service import USE_CLIENT_DEFAULT
from ._sync_client import Client, Module, Request, connect

__all__ = ["CallInterrupted", "ShellNamespace", "main", "one_line", "raised_by_the_client"]

#: Seconds the shell waits for the gateway's reply to an abort asked by Ctrl-C.
ABORT_TIMEOUT = 10.0

BANNER = """aiogenomix shell on {url} (session {session}), genomix {version}
Modules: {modules}
  demo.GotoPosition?          the generated documentation      load("kemar")   load a component
  demo.GotoPosition(0.5)      call and wait; Ctrl-C aborts it  requests()      the ack=True requests
  demo.GotoPosition(0.5, ack=True)   return at once; the end is printed when it comes
  %tb                         the full traceback of the last error (the client's errors print as one line)
"""


#: The attribute that marks an exception the client raised before sending a service (its value: the
#: service's name), so that its line says the robot was asked nothing.
_NOT_SENT = "_aiogenomix_not_sent"


class CallInterrupted(KeyboardInterrupt):
    """A Ctrl-C during a blocking call, after the shell did what it could about the request.

    A KeyboardInterrupt still (``except KeyboardInterrupt`` catches it); its
    message says what became of the request.
    """


def one_line(exc: BaseException, *, where: bool = True) -> str:
    """*exc* as the shell prints it: one line saying what went wrong and, with *where*, which request.

    ``TOO_FAR_AWAY: overshoot=1.0 (GotoPosition, request demo::0)``;
    ``interrupted by Stop (GotoPosition, request demo::0)``;
    ``RequestTimeout: GotoPosition (demo::0) did not end within 1 s; ...``.
    """
    if isinstance(exc, CallInterrupted):
        return str(exc)
    if not isinstance(exc, RemoteError):
        refused = getattr(exc, _NOT_SENT, None) if where else None
        return f"{type(exc).__name__}: {exc}" + (f" ({refused}: nothing was sent)" if refused else "")
    if isinstance(exc, Interrupted):
        text = f"interrupted by {exc.by or 'an unknown cause'}"
    else:
        # The gateway's sentence, when it sent one, already says what its detail holds.
        said = exc.message or ", ".join(f"{k}={v!r}" for k, v in exc.detail.items())
        text = short_name(exc.ex) + (f": {said}" if said else "")
    named = [w for w in (exc.service, exc.request_id and f"request {exc.request_id}") if w] if where else []
    return text + (f" ({', '.join(named)})" if named else "")


class ShellModule:
    """A module as the shell shows it: its calls announce their ends, report errors in one line, and take Ctrl-C.

    Its members are plain attributes, so that completion (Jedi reads them without running code) sees
    the services with their signatures.
    """

    def __init__(self, module: Module, namespace: ShellNamespace) -> None:
        self._module = module
        kinds = {s["name"]: s["kind"] for s in module.__info__["services"]}
        ports = {p["name"] for p in module.__info__.get("ports", [])}
        for name in dir(module):
            member = getattr(module, name)
            if name in kinds and callable(member):
                member = namespace.announced(member, kinds[name])
            elif name in ports and callable(member):
                member = namespace.guarded(member, f"the read of {module.__info__['name']}.{name}")
            setattr(self, name, member)
        self.__doc__ = module.__doc__

    def __repr__(self) -> str:
        return repr(self._module)


class ShellNamespace:
    """The names of a shell session: the client ``g``, one name per loaded module, ``load`` and ``requests``.

    Args:
        client: The connected client.
        print_line: Prints one line (above the prompt when called from another thread).
    """

    def __init__(self, client: Client, print_line: Callable[[str], None] = print) -> None:
        self.client = client
        self.acked: list[Request] = []
        self._print = print_line
        # Requests left running by a Ctrl-C (functions): their end is printed by whichever of the
        # callback and the Ctrl-C handler takes them out of this set, exactly once.
        self._detached: set[Request] = set()
        self._detached_lock = threading.Lock()
        self._sender = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="aiogenomix-shell-send")
        # Its one thread starts now, not at the first call: a call's submit then only queues the send,
        # so a Ctrl-C cannot land in the wait for a new thread to start (a busy machine makes that
        # wait long) and escape the handling below as a raw traceback.
        self._sender.submit(lambda: None).result()
        self.names: dict[str, Any] = {"g": client, "load": self.load, "requests": self.requests}
        for instance in client.loaded():
            self._add(client.module(instance))

    def close(self) -> None:
        """Stop the sender thread (once the client is closed, a send still under way fails at once)."""
        self._sender.shutdown(wait=True, cancel_futures=True)

    def _add(self, module: Module) -> ShellModule:
        shown = ShellModule(module, self)
        instance = module.__info__["name"]
        if instance.isidentifier() and not keyword.iskeyword(instance):
            self.names[instance] = shown
        return shown

    def load(self, name: str, *argv: str) -> ShellModule:
        """Load a component (or find it loaded) and name it in the shell."""
        return self._add(self.guarded(self.client.load, f"the load of {name}")(name, *argv))

    def requests(self) -> None:
        """List the requests sent with ``ack=True`` (or left running by Ctrl-C) in this shell, with their status."""
        if not self.acked:
            self._print("no request sent with ack=True yet")
        for request in self.acked:
            self._print(f"{request.id:<16} {request.service:<24} {request.status.value}")

    def guarded(self, call: Callable[..., Any], what: str) -> Callable[..., Any]:
        """*call*, whose Ctrl-C says in one line what was given up rather than showing the client's threads."""

        @functools.wraps(call)
        def guarded_call(*args: Any, **kwargs: Any) -> Any:
            try:
                return call(*args, **kwargs)
            except CallInterrupted:
                raise
            except KeyboardInterrupt:
                raise CallInterrupted(f"Ctrl-C: gave up waiting for {what}") from None

        return guarded_call

    def announced(self, service: Callable[..., Any], kind: str = "activity") -> Callable[..., Any]:
        """*service* as the shell calls it.

        With ``ack=True`` its requests are recorded and their end is printed when it comes. A blocking
        call waits on the request's handle, so that a Ctrl-C knows the request: an activity is aborted,
        a function (or attribute), which genom cannot abort, is left to run to its end.

        Args:
            service: A generated service function of the client.
            kind: The service's kind in ``/info``: ``activity``, ``function`` or ``attribute``.
        """

        @functools.wraps(service)
        def call(*args: Any, **kwargs: Any) -> Any:
            if kwargs.get("oneway"):
                return service(*args, **kwargs)
            blocking = not kwargs.get("ack")
            callback = kwargs.get("callback")
            if blocking:
                kwargs["callback"] = self._chained(self._detached_ended, callback)
            elif callback is None:
                kwargs["callback"] = self._ended
            kwargs["ack"] = True
            # Sent from the sender thread: a Ctrl-C in this one never cancels a send half-way, which
            # would leave a request running that nobody knows.
            sending = self._sender.submit(service, *args, **kwargs)
            try:
                request = result_of(sending)
            except KeyboardInterrupt:
                request = self._reply_after_ctrl_c(sending, service.__name__)
                if not blocking:
                    self.acked.append(request)
                raise self._interrupted(request, kind, announced=not blocking) from None
            except Exception as exc:
                if not isinstance(exc, GenomixError):
                    # The call itself is wrong (a type, a misspelled keyword): the client refused it.
                    setattr(exc, _NOT_SENT, service.__name__)
                raise
            if not blocking:
                self.acked.append(request)
                return request
            try:
                return request.result(kwargs.get("timeout", USE_CLIENT_DEFAULT))
            except KeyboardInterrupt:
                raise self._interrupted(request, kind, announced=False) from None

        vars(call)["__signature__"] = inspect.signature(service)
        return call

    @staticmethod
    def _reply_after_ctrl_c(sending: concurrent.futures.Future[Request], service: str) -> Request:
        """The request whose send a Ctrl-C came during: the gateway's reply names it, and comes soon."""
        try:
            return result_of(sending)
        except KeyboardInterrupt:
            raise CallInterrupted(f"Ctrl-C again: stopped waiting for the gateway's reply to {service}; "
                                  "it may run (g.pending() does not know it)") from None

    def _interrupted(self, request: Request, kind: str, *, announced: bool) -> CallInterrupted:
        """Do what Ctrl-C asks of a running request; the exception says in one line what became of it.

        Args:
            request: The request the interrupted call sent.
            kind: Its service's kind.
            announced: Whether its end is printed already (sent with ``ack=True``).
        """
        what = f"{request.service} ({request.id})"
        if kind != "activity":
            if not announced:
                with self._detached_lock:
                    self._detached.add(request)
                self.acked.append(request)
                if request.done:  # it ended as the Ctrl-C came: print its end unless its callback did
                    self._detached_ended(request)
            return CallInterrupted(f"Ctrl-C: {what} is a {kind}, which genom cannot abort: it runs to its end, "
                                   "printed here when it comes")
        try:
            request.abort(ABORT_TIMEOUT)
        except KeyboardInterrupt:
            return CallInterrupted(f"Ctrl-C again: stopped waiting for the abort of {what}; "
                                   "it may still run (g.pending())")
        except GenomixError as exc:
            return CallInterrupted(f"Ctrl-C: the abort of {what} failed: {one_line(exc)}; "
                                   "it may still run (g.pending())")
        error = request.exception
        ended = one_line(error, where=False) if error is not None else f"it had ended ({request.status.value})"
        return CallInterrupted(f"Ctrl-C: asked the gateway to abort {what}: {ended}")

    @staticmethod
    def _chained(first: Callable[[Request], None], then: Callable[[Request], Any] | None) -> Callable[[Request], Any]:
        if then is None:
            return first

        def both(request: Request) -> Any:
            first(request)
            return then(request)

        return both

    def _detached_ended(self, request: Request) -> None:
        # The end of every blocking call passes here; only those Ctrl-C left running are printed.
        with self._detached_lock:
            if request not in self._detached:
                return
            self._detached.discard(request)
        self._ended(request)

    def _ended(self, request: Request) -> None:
        # Runs on the client's callback thread: the line goes above the prompt (patch_stdout).
        outcome = request.status.value
        if request.exception is not None:
            outcome += f": {one_line(request.exception, where=False)}"
        elif request.output:
            outcome += f": {request.output}"
        self._print(f"[{request.id} {request.service} {outcome}]")

    def enum_values(self, line: str) -> list[str] | None:
        """The enum values a keyword argument being typed at the end of *line* can take, quoted; else None."""
        found = re.search(r"(\w+)\.(\w+)\((?:[^()]*,)?\s*(\w+)\s*=\s*(['\"]?)(\w*)$", line)
        if not found:
            return None
        instance, service, param, quote, _ = found.groups()
        module = self.names.get(instance)
        if not isinstance(module, ShellModule):
            return None
        for spec in module._module.__info__["services"]:
            if spec["name"] != service:
                continue
            for p in spec["parameters"]:
                if p["name"] == param and p["type"]["kind"] == "enum":
                    quote = quote or '"'
                    return [f"{quote}{v.rsplit('::', 1)[-1]}{quote}" for v in p["type"]["values"]]
        return None


def _install_enum_completion(shell: Any, namespace: ShellNamespace) -> None:
    """Complete enum values of keyword arguments (Jedi completes modules, services and keywords)."""
    from IPython.core.completer import SimpleCompletion, context_matcher

    @context_matcher()  # type: ignore[misc]
    def enum_matcher(context: Any) -> dict[str, Any]:
        values = namespace.enum_values(context.text_until_cursor)
        if values is None:
            return {"completions": [], "suppress": False}
        token = re.search(r"['\"]?\w*$", context.text_until_cursor).group(0)  # type: ignore[union-attr]
        matches = [v for v in values if v.startswith(token) or v.strip("'\"").startswith(token)]
        return {"completions": [SimpleCompletion(text=v, type="enum") for v in matches], "suppress": True,
                "matched_fragment": token}

    shell.Completer.custom_matchers.append(enum_matcher)


def raised_by_the_client(exc: BaseException) -> bool:
    """Whether *exc* is an error of the client: the gateway's, a component's, or a call the client refused.

    That is, a :class:`GenomixError`, a Ctrl-C the shell handled, or any exception raised from
    the client's code (a wrong argument type, a misspelled keyword, the sender thread's
    ``concurrent.futures`` in between); an exception of the user's own code is not.
    """
    if isinstance(exc, (GenomixError, CallInterrupted)):
        return True
    return any(frame.f_code.co_filename.startswith(_CLIENT_FILES) for frame, _ in traceback.walk_tb(exc.__traceback__))


#: Where the client's modules are (by file: under ``python -m`` this module is ``__main__``, and a call refused
#: as its arguments are bound has no frame but the shell's wrapper).
_CLIENT_FILES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "")


def _install_one_line_errors(shell: Any) -> None:
    """Print the client's errors, and Ctrl-C's outcome, as one line; ``%tb`` in full; others as IPython does."""
    hinted = False

    def show(shell: Any, etype: type[BaseException], value: BaseException, tb: Any, tb_offset: Any = None) -> None:
        nonlocal hinted
        if not raised_by_the_client(value):
            shell.showtraceback((etype, value, tb), tb_offset=tb_offset)
            return
        # What %tb (and %debug) read: the full traceback stays one magic away.
        sys.last_type, sys.last_value, sys.last_traceback = etype, value, tb
        if sys.version_info >= (3, 12):
            sys.last_exc = value
        line = one_line(value)
        if not hinted:
            line += "   (%tb shows the traceback)"
            hinted = True
        print(line)

    shell.set_custom_exc((Exception, CallInterrupted), show)


def _arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="aiogenomix-shell", description="An IPython session already connected to an aiogenomix gateway.")
    parser.add_argument("address", nargs="?", default=None, help="the gateway, HOST:PORT (default localhost:8080)")
    parser.add_argument("--token", help="the gateway's --token")
    parser.add_argument("--session", help="a session name (default: the gateway chooses one)")
    return parser.parse_args(argv)


def _take_ctrl_c() -> None:
    """At a terminal, make Ctrl-C raise KeyboardInterrupt even when the shell was started with SIGINT ignored.

    A program started in the background by a script without job control (``cmd &`` in ``sh -c``, a CI
    runner, ``nohup``) inherits SIGINT ignored, and Python then leaves it ignored: a Ctrl-C typed at
    the shell's terminal would do nothing, and a blocking call would never end. An interactive shell
    owns its terminal's Ctrl-C (as bash does), so it takes SIGINT back when its input is a terminal.
    """
    if sys.stdin.isatty() and signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the shell; the exit status is 0 when the session ended normally."""
    args = _arguments(argv)
    _take_ctrl_c()
    options = {k: v for k, v in (("token", args.token), ("session", args.session)) if v}
    try:
        client = connect(args.address, **options)
    except Exception as exc:  # an unreachable gateway is one line, not a traceback
        print(f"aiogenomix-shell: {exc}", file=sys.stderr)
        return 1
    from IPython.terminal.ipapp import TerminalIPythonApp
    from prompt_toolkit.patch_stdout import StdoutProxy
    from traitlets.config import Config

    from ._shell_output import CellOutput

    namespace: ShellNamespace | None = None
    try:
        namespace = ShellNamespace(client)
        config = Config()
        config.TerminalInteractiveShell.banner1 = BANNER.format(
            url=client.url, session=client.session, version=client.genomix_version,
            modules=", ".join(n for n, v in namespace.names.items() if isinstance(v, ShellModule)) or "none loaded")
        config.TerminalInteractiveShell.confirm_exit = False
        app = TerminalIPythonApp.instance(config=config, user_ns=namespace.names)
        app.initialize([])
        _install_enum_completion(app.shell, namespace)
        _install_one_line_errors(app.shell)
        # Lines printed by other threads (the ends of ack=True requests) go above the prompt, not into it;
        # the cell's own output before the next prompt (CellOutput).
        with StdoutProxy(raw=True) as proxy, \
                contextlib.redirect_stdout(CellOutput(sys.stdout, proxy)), \
                contextlib.redirect_stderr(CellOutput(sys.stderr, proxy)):
            app.start()
    finally:
        client.close()
        if namespace is not None:
            namespace.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
