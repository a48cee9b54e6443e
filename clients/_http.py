"""Plain GET requests to the gateway, with their failures turned into the client's exceptions."""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any

import aiohttp
import orjson

from ._errors import ProtocolError, RequestTimeout, TransportError, remote_error
from ._wire import StatusObject, parse_status, request_number

__all__ = ["HttpGateway"]


class HttpGateway:
    """The request/reply side of a gateway (the event stream lives in ``_listen``).

    Args:
        base: ``http://host:port``.
        session: The aiohttp session (owned by the client).
        session_name: The genomix session, sent as ``s=`` with every request.
    """

    def __init__(self, base: str, session: aiohttp.ClientSession, session_name: str = "") -> None:
        self.base = base
        self.http = session
        self.session_name = session_name

    async def get(self, path: str, params: Mapping[str, str] | None = None, *, timeout: float | None = None,
                  module: str | None = None, service: str | None = None) -> tuple[str, bytes]:
        """GET *path*; return the content type and body of a 2xx reply.

        Raises:
            RemoteError: for an error reply (the class chosen by its ``ex``).
            TransportError: when the gateway cannot be reached or drops the connection.
            RequestTimeout: when *timeout* expires.
            ProtocolError: for an error reply without a genomix error body.
        """
        query = dict(params or {})
        if self.session_name:
            query.setdefault("s", self.session_name)
        try:
            async with asyncio.timeout(timeout):
                async with self.http.get(self.base + path, params=query) as reply:
                    body = await reply.read()
                    ctype = reply.content_type
                    status = reply.status
        except TimeoutError:
            raise RequestTimeout(f"GET {path} got no reply within {timeout} s") from None
        except aiohttp.ClientError as exc:
            raise TransportError(f"GET {self.base}{path} failed: {exc or type(exc).__name__}") from exc
        except OSError as exc:
            raise TransportError(f"GET {self.base}{path} failed: {exc}") from exc
        if 200 <= status < 300:
            return ctype, body
        raise self.error_for(status, body, path, module, service)

    @staticmethod
    def error_for(status: int, body: bytes, path: str, module: str | None = None,
                  service: str | None = None) -> Exception:
        """The exception for an error reply (a RemoteError when it has a genomix body)."""
        try:
            data = orjson.loads(body) if body else None
        except orjson.JSONDecodeError:
            data = None
        if isinstance(data, Mapping) and isinstance(data.get("ex"), str):
            return remote_error(data, module=module, service=service)
        text = body.decode("utf-8", errors="replace").strip()[:200]
        return ProtocolError(f"GET {path}: HTTP {status} without a genomix error body: {text!r}")

    async def get_json(self, path: str, params: Mapping[str, str] | None = None, **kwargs: Any) -> Any:
        """GET *path* and decode its JSON reply.

        Raises:
            ProtocolError: when the reply is not JSON.
        """
        _, body = await self.get(path, params, **kwargs)
        try:
            return orjson.loads(body)
        except orjson.JSONDecodeError:
            raise ProtocolError(f"GET {path}: expected JSON, got {body[:200]!r}") from None

    async def get_text(self, path: str, params: Mapping[str, str] | None = None, **kwargs: Any) -> str:
        """GET *path* and return its text reply."""
        _, body = await self.get(path, params, **kwargs)
        return body.decode("utf-8")

    # -- requests of a module ------------------------------------------------------------------

    async def status(self, module: str, request_id: str, timeout: float | None = None) -> StatusObject:
        """``/module/M/status/RQ``."""
        return parse_status(await self.get_json(f"/module/{module}/status/{request_number(request_id)}",
                                                timeout=timeout, module=module))

    async def abort(self, module: str, request_id: str, timeout: float | None = None) -> StatusObject:
        """``/module/M/abort/RQ``: the status after the interruption."""
        return parse_status(await self.get_json(f"/module/{module}/abort/{request_number(request_id)}",
                                                timeout=timeout, module=module))

    async def clean(self, module: str, request_id: str) -> None:
        """``/module/M/clean/RQ``: forget an ended request."""
        await self.get(f"/module/{module}/clean/{request_number(request_id)}", module=module)

