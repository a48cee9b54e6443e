r"""Decoding the ``input`` query parameter: genom3's lenient JSON, or a readable refusal.

Strict JSON goes through orjson.  What orjson refuses goes through Python's
parser, which also takes what genom3 emits and accepts (raw control characters
in strings, ``NaN``).  That second parser has limits of its own (integers of
more than 4300 digits, nesting deeper than the recursion limit) and accepts a
lone UTF-16 surrogate (``"\ud800"``), which is no character at all: each is
refused here as bad input rather than failing later as an internal error.

A JSON object that names a member twice (``{"posRef":0.3,"posRef":0.6}``) is refused,
as a query parameter given twice is: both parsers would keep the last one silently,
and the robot would go where the client may not have meant.  orjson cannot say so,
and the input is parsed on every send: the check costs a count, not a second parse.
Outside strings, a colon in JSON text is only ever a member's, so an input whose
colons are as many as the members orjson kept names none twice; only an input with
colons inside its strings (or one that does name a member twice) is parsed again,
by Python's parser, which sees every member.
"""

from __future__ import annotations

import json
import sys
from typing import Any

import orjson

from ._errors import BadQuery

__all__ = ["parse_input"]


def parse_input(text: str | None) -> Any:
    """Decode the ``input`` query parameter.

    Args:
        text: The parameter as received (None or blank: no input).

    Returns:
        The JSON value.

    Raises:
        BadQuery: saying why the text is not JSON data (and where, when the syntax is wrong).
    """
    if text is None or not text.strip():
        return None
    try:
        value = orjson.loads(text)
    except orjson.JSONDecodeError:
        return _lenient(text)
    if type(value) in _CONTAINERS:
        colons = text.count(":")
        # A flat object with as many members as colons (the usual input) needs no walk.
        if not (type(value) is dict and colons == len(value)) and colons != _members(value):
            _lenient(text)  # colons in strings, or a member named twice: this parser tells which
    return value


class _Repeated(Exception):
    """A JSON object names a member twice."""


def _unique(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """Python's parser's object hook: the object, unless it names a member twice."""
    value = dict(pairs)
    if len(value) != len(pairs):
        seen: set[str] = set()
        for name, _ in pairs:
            if name in seen:
                raise _Repeated(name)
            seen.add(name)
    return value


def _members(value: dict[str, Any] | list[Any]) -> int:
    """How many members the objects in *value* (as orjson made it) have, at most.

    A list whose first item is a plain value is taken to hold no object: an undercount only sends
    an input to the second parse.  (On every send: written for the usual input, a small flat object.)
    """
    count = 0
    stack: list[Any] = [value]
    while stack:
        item = stack.pop()
        if type(item) is dict:
            count += len(item)
            for member in item.values():
                if type(member) is dict or (type(member) is list and member and type(member[0]) in _CONTAINERS):
                    stack.append(member)
        elif item and type(item[0]) in _CONTAINERS:  # a list (of objects or lists, by its first item)
            stack.extend(member for member in item if type(member) in _CONTAINERS)
    return count


_CONTAINERS = (dict, list)


def _lenient(text: str) -> Any:
    """Python's parser, for what orjson refuses (genom3's raw control characters, ``NaN``) or cannot check."""
    try:
        value = json.loads(text, strict=False, object_pairs_hook=_unique)
    except _Repeated as exc:
        name = str(exc.args[0])
        shown = ascii(name if len(name) <= 40 else name[:37] + "...")
        raise BadQuery(f"input names the member {shown} twice: give each member once") from None
    except json.JSONDecodeError as exc:
        raise BadQuery(f"input is not valid JSON: {exc.msg} at character {exc.pos}") from None
    except RecursionError:
        raise BadQuery("input is nested too deeply to be read") from None
    except ValueError:
        # The only other ValueError of the parser: int() refuses that many digits.
        raise BadQuery(f"input holds an integer of more than {sys.get_int_max_str_digits()} digits") from None
    if _holds_lone_surrogate(value):
        raise BadQuery('input holds a lone UTF-16 surrogate (an escape such as "\\ud800" without its pair), '
                       "which is no character")
    return value


def _holds_lone_surrogate(value: Any) -> bool:
    # Iterative: the value may be nested as deeply as the parser allowed.
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, str):
            if not item.isascii():
                try:
                    item.encode()
                except UnicodeEncodeError:
                    return True
        elif isinstance(item, list):
            stack.extend(item)
        elif isinstance(item, dict):
            stack.extend(item)
            stack.extend(item.values())
    return False
