"""How the HTTP server's refusals of client input are logged: one line at DEBUG, never a traceback.

aiohttp's server logs a request its parser refuses (a malformed head, a field given
twice, a body longer than it says) at ERROR with the parser's traceback.  Those are
the client's mistakes, and anyone who can reach the port could fill the log with
them (issue 29: 407 kB for 500 requests in 0.9 s).  The gateway hands aiohttp's
server :data:`SERVER_LOG` instead of aiohttp's own logger (``handler_args``, so that
whatever runner serves the application uses it): a refusal of client input is one
line at DEBUG, like the gateway's own refusals; anything else (a fault of the
gateway) keeps its level and its traceback.
"""

from __future__ import annotations

import logging
from collections.abc import MutableMapping
from typing import Any

from aiohttp.http_exceptions import HttpProcessingError

__all__ = ["SERVER_LOG"]


class _ServerLog(logging.LoggerAdapter[logging.Logger]):
    """aiohttp's server logger, with the refusals of client input turned into one line at DEBUG."""

    def process(self, msg: Any, kwargs: MutableMapping[str, Any]) -> tuple[Any, MutableMapping[str, Any]]:
        return msg, kwargs

    def log(self, level: int, msg: object, *args: object, **kwargs: Any) -> None:  # noqa: D102
        exc = kwargs.get("exc_info")
        if isinstance(exc, HttpProcessingError):
            kwargs.pop("exc_info")
            # One line: the parser's message may show the offending bytes on a line of their own.
            self.logger.debug("refused a request: %s (%s %s)", str(msg) % args if args else msg, exc.code,
                              " ".join(str(exc.message).split()))
            return
        super().log(level, msg, *args, **kwargs)


#: The logger the gateway gives aiohttp's server (``aiohttp.server``, as aiohttp names its own).
SERVER_LOG = _ServerLog(logging.getLogger("aiohttp.server"))
