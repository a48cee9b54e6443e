"""``aiogenomix-shell [HOST:PORT]``: an IPython session already connected to a gateway, with completion.

What eltclsh gave Tcl users, for Python: the loaded modules are names
(``demo``), their services complete on Tab (``demo.Go<Tab>``), so do keyword
arguments (``demo.GotoPosition(po<Tab>``) and enum values
(``demo.SetSpeed(speedRef="<Tab>``); ``demo.GotoPosition?`` shows the generated
documentation.  A call with ``ack=True`` returns at once; its end is printed
above the prompt when it comes, and ``requests()`` lists every such request
with its status.
"""

from __future__ import annotations

import argparse
import functools
import inspect
import keyword
import re
import sys
from collections.abc import Callable, Sequence
from typing import Any

from ._sync_client import Client, Module, Request, connect

__all__ = ["main", "ShellNamespace"]

BANNER = """aiogenomix shell on {url} (session {session}), genomix {version}
Modules: {modules}
  demo.GotoPosition?          the generated documentation      load("kemar")   load a component
  demo.GotoPosition(0.5)      call and wait                    requests()      the ack=True requests
  demo.GotoPosition(0.5, ack=True)   return at once; the end is printed when it comes
"""


class ShellModule:
    """A module as the shell shows it: its services record and announce the requests sent with ``ack=True``.

    Its members are plain attributes, so that completion (Jedi reads them without running code) sees
    the services with their signatures.
    """

    def __init__(self, module: Module, namespace: ShellNamespace) -> None:
        self._module = module
        services = {s["name"] for s in module.__info__["services"]}
        for name in dir(module):
            member = getattr(module, name)
            setattr(self, name, namespace.announced(member) if name in services and callable(member) else member)
        self.__doc__ = module.__doc__

    def __repr__(self) -> str:
        return repr(self._module)


class ShellNamespace:
    """The names of a shell session: the client ``g``, one name per loaded module, ``load`` and ``requests``."""

    def __init__(self, client: Client, print_line: Callable[[str], None] = print) -> None:
        self.client = client
        self.acked: list[Request] = []
        self._print = print_line
        self.names: dict[str, Any] = {"g": client, "load": self.load, "requests": self.requests}
        for instance in client.loaded():
            self._add(client.module(instance))

    def _add(self, module: Module) -> ShellModule:
        shown = ShellModule(module, self)
        instance = module.__info__["name"]
        if instance.isidentifier() and not keyword.iskeyword(instance):
            self.names[instance] = shown
        return shown

    def load(self, name: str, *argv: str) -> ShellModule:
        """Load a component (or find it loaded) and name it in the shell."""
        return self._add(self.client.load(name, *argv))

    def requests(self) -> None:
        """List the requests sent with ``ack=True`` in this shell, with their status now."""
        if not self.acked:
            self._print("no request sent with ack=True yet")
        for request in self.acked:
            self._print(f"{request.id:<16} {request.service:<24} {request.status.value}")

    def announced(self, service: Callable[..., Any]) -> Callable[..., Any]:
        """*service*, recording its ``ack=True`` requests and printing their end when it comes."""

        @functools.wraps(service)
        def call(*args: Any, **kwargs: Any) -> Any:
            if kwargs.get("ack") and kwargs.get("callback") is None:
                kwargs["callback"] = self._ended
            outcome = service(*args, **kwargs)
            if isinstance(outcome, Request):
                self.acked.append(outcome)
            return outcome

        call.__signature__ = inspect.signature(service)  # type: ignore[attr-defined]
        return call

    def _ended(self, request: Request) -> None:
        # Runs on the client's callback thread: the line goes above the prompt (patch_stdout).
        outcome = request.status.value
        if request.exception is not None:
            outcome += f": {request.exception}"
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


def _arguments(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="aiogenomix-shell", description="An IPython session already connected to an aiogenomix gateway.")
    parser.add_argument("address", nargs="?", default=None, help="the gateway, HOST:PORT (default localhost:8080)")
    parser.add_argument("--token", help="the gateway's --token")
    parser.add_argument("--session", help="a session name (default: the gateway chooses one)")
    return parser.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the shell; the exit status is 0 when the session ended normally."""
    args = _arguments(argv)
    options = {k: v for k, v in (("token", args.token), ("session", args.session)) if v}
    try:
        client = connect(args.address, **options)
    except Exception as exc:  # an unreachable gateway is one line, not a traceback
        print(f"aiogenomix-shell: {exc}", file=sys.stderr)
        return 1
    from IPython.terminal.ipapp import TerminalIPythonApp
    from prompt_toolkit.patch_stdout import patch_stdout
    from traitlets.config import Config

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
        # Lines printed by other threads (the ends of ack=True requests) go above the prompt, not into it.
        with patch_stdout(raw=True):
            app.start()
    finally:
        client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
