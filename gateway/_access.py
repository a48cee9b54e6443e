"""Who may reach the gateway from a web browser: Host and Origin checks, and the headers that go with them.

Every genomix action is a GET, so any web page a user opens could otherwise
move the robot: an ``<img src="http://127.0.0.1:8080/module/kemar/send/...">``
is a request like any other (cross-site request forgery), and a name that an
attacker's DNS points at 127.0.0.1 reaches the gateway as a "same-origin" page
(DNS rebinding).  Programs (curl, MATLAB, Tcl, Python) send neither ``Origin``
nor ``Sec-Fetch-Site``, so these checks cost them nothing:

* **Host**: a request must name the gateway by an IP address, ``localhost``,
  this machine's name, or a name the operator allows (``--allowed-host``).  A
  rebinding page names the attacker's domain and is refused.
* **Origin**: a browser request from another origin is refused unless the
  operator allows that origin (``--allow-origin``), which then also gets the
  CORS headers on every reply (errors, refusals and event streams included)
  and answers to its preflights, so that a web app or Swagger UI served
  elsewhere can use the gateway, its token included.  A request a browser marks as cross-site
  with no ``Origin`` (an image, a link, a form) is refused too, except a
  navigation to the read-only pages ``/``, ``/console`` and ``/docs``, and
  Swagger UI's files.

Every reply says ``X-Content-Type-Options: nosniff`` (in the headers every reply
starts from, ``_replies.SERVER_HEADER``); the console page gets a
Content-Security-Policy that lets only its own script and style run.
"""

from __future__ import annotations

import base64
import hashlib
import ipaddress
import re
import socket
from collections.abc import Iterable, Mapping
from typing import Any

from aiohttp import web

from ._replies import SERVER_HEADER

__all__ = ["AccessPolicy", "browser_refusal", "other_origin", "target_authority", "allow_origin", "preflight_reply",
           "console_policy", "inline_hashes"]

#: How many distinct Host headers the policy remembers its verdict on.
_REMEMBERED_HOSTS = 256
#: What another site may link to or load without asking (a navigation, a script or style tag): pages that
#: show and do not act, and Swagger UI's files, which a page served elsewhere loads from here.
_NAVIGABLE = frozenset({"/", "/console", "/docs", "/docs/swagger-ui-bundle.js", "/docs/swagger-ui.css"})


def _hostname(host: str) -> str:
    """The name part of a Host header (``[::1]:8080`` → ``::1``, ``Name:80`` → ``name``)."""
    if host.startswith("["):
        return host[1:host.find("]")].lower() if "]" in host else host.lower()
    return host.rsplit(":", 1)[0].lower() if host.count(":") == 1 else host.lower()


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


class AccessPolicy:
    """The names and origins the gateway answers browsers from.

    Args:
        allowed_hosts: Host names accepted besides IP addresses, ``localhost`` and this
            machine's names (``*`` accepts any name).
        allowed_origins: Web origins (``https://lab.example:8443``) whose pages may use
            the gateway; ``*`` allows every origin (not advised).
    """

    def __init__(self, allowed_hosts: Iterable[str] = (), allowed_origins: Iterable[str] = ()) -> None:
        machine = {socket.gethostname().lower(), socket.getfqdn().lower()}
        self.hosts = {"localhost", *machine, *(h.lower() for h in allowed_hosts)}
        self.origins = {o.rstrip("/") for o in allowed_origins}
        # Host header -> verdict.  A client sends the same Host on every request, and parsing
        # it as an IP address was a tenth of the gateway's time under load; the cache is
        # bounded because the header is the client's to choose.
        self._verdicts: dict[str, bool] = {}

    def host_allowed(self, host: str | None) -> bool:
        """Whether a request naming *host* may be answered (no Host at all: an HTTP/1.0 program)."""
        if not host:
            return True
        verdict = self._verdicts.get(host)
        if verdict is None:
            name = _hostname(host)
            verdict = "*" in self.hosts or _is_ip(name) or name in self.hosts or name.endswith(".localhost")
            if len(self._verdicts) >= _REMEMBERED_HOSTS:
                self._verdicts.clear()
            self._verdicts[host] = verdict
        return verdict

    def origin_allowed(self, origin: str) -> bool:
        """Whether pages of *origin* (other than the gateway's own) may use the gateway."""
        return "*" in self.origins or origin.rstrip("/") in self.origins  # as the operator's: file:// is file:


def browser_refusal(policy: AccessPolicy, path: str, headers: Mapping[str, str], scheme: str = "http",
                    host: str | None = None) -> tuple[dict[str, Any] | None, str | None]:
    """Apply *policy* to a request for *path* with *headers* (looked up by lower-case name).

    Args:
        policy: The names and origins allowed.
        path: The request's path.
        headers: Its header fields.
        scheme: How it reached the gateway.
        host: The host the request names: the authority of an absolute-form target
            (``GET http://name/...``), which HTTP/1.1 makes the request's host whatever
            its ``Host`` says; None to take the ``Host`` field.

    Returns:
        ``(error body, None)`` to refuse it (403), or ``(None, origin)`` to answer
        it, *origin* being the other-site origin the reply must carry the CORS
        headers for (None for a program, or a page of the gateway's own origin).
    """
    if host is None:
        host = headers.get("host")
    if not policy.host_allowed(host):
        return _forbidden(f"this gateway does not answer to the name {_shown(host or '')} "
                          "(its operator can allow it with --allowed-host)"), None
    origin = headers.get("origin")
    if origin is None:
        # A program (no Origin), or a browser request it may not have made from another site.
        if headers.get("sec-fetch-site", "") in ("cross-site", "same-site") and path not in _NAVIGABLE:
            return _forbidden("a request from another web site may not use this gateway"), None
        return None, None
    if other_origin(headers, scheme, host) is not None:
        if not policy.origin_allowed(origin):
            return _forbidden(f"pages from {_shown(origin)} may not use this gateway "
                              "(its operator can allow them with --allow-origin)"), None
        return None, origin
    return None, None


def target_authority(target: str) -> str | None:
    """The authority (``name[:port]``) of a request target in absolute form (``http://name:port/path``), else None."""
    scheme, separator, rest = target.partition("://")
    if not separator or scheme.lower() not in ("http", "https"):
        return None
    authority = rest.split("/", 1)[0].split("?", 1)[0]
    return authority.rpartition("@")[2]  # without user information, which HTTP/1.1 forbids there anyway


def other_origin(headers: Mapping[str, str], scheme: str = "http", host: str | None = None) -> str | None:
    """The ``Origin`` of a request made by a page of another origin than the gateway's own (else None).

    *host* is the host the request names when it is not its ``Host`` field (see :func:`browser_refusal`).
    """
    origin = headers.get("origin")
    if origin is None:
        return None
    return origin if origin != f"{scheme}://{headers.get('host') if host is None else host}" else None


#: What a page of an allowed origin may send (the token, JSON bodies, an EventSource's reconnect).
_ALLOWED_METHODS = "GET, POST, OPTIONS"
_ALLOWED_HEADERS = "Authorization, Content-Type, Accept, Last-Event-ID, Cache-Control"
#: How long a browser may keep a preflight's answer (seconds).
_PREFLIGHT_MAX_AGE = "600"


def allow_origin(response: web.StreamResponse, origin: str) -> None:
    """Let pages of *origin* (allowed by the policy) read *response* (before it is prepared)."""
    response.headers["Access-Control-Allow-Origin"] = origin
    response.headers["Vary"] = "Origin"


def preflight_reply(origin: str) -> web.Response:
    """The answer to a browser's preflight (``OPTIONS``) from an allowed *origin*: 204 and what it may send."""
    response = web.Response(status=204, headers={
        "Access-Control-Allow-Methods": _ALLOWED_METHODS, "Access-Control-Allow-Headers": _ALLOWED_HEADERS,
        "Access-Control-Max-Age": _PREFLIGHT_MAX_AGE, **SERVER_HEADER})
    allow_origin(response, origin)
    return response


def _shown(header: str) -> str:
    """A header value fit for a JSON message: quoted, bytes that are not UTF-8 escaped."""
    return ascii(header.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace"))


def _forbidden(message: str) -> dict[str, Any]:
    return {"ex": "::genomix::forbidden", "message": message}


def inline_hashes(page: bytes, tag: str) -> str:
    """The CSP hashes (``'sha256-...'``) of the inline ``<tag>`` blocks of *page* (a block with ``src`` is empty)."""
    blocks = re.findall(rb"<" + tag.encode() + rb"[^>]*>(.*?)</" + tag.encode() + rb">", page, re.S)
    return " ".join(f"'sha256-{base64.b64encode(hashlib.sha256(b).digest()).decode()}'" for b in blocks if b)


def console_policy(page: bytes) -> str:
    """The Content-Security-Policy of the console *page*: its inline script and style, and the gateway's files.

    The gateway's own files are its plotting library (uPlot, served from the package); uPlot sizes its
    elements through the CSSOM (``element.style``), which no policy restricts.
    """
    return (f"default-src 'none'; script-src 'self' {inline_hashes(page, 'script')}; style-src 'self' "
            f"{inline_hashes(page, 'style')}; connect-src 'self'; img-src 'self' data: blob:; base-uri 'none'; "
            "form-action 'none'; frame-ancestors 'none'")
