r"""Decoding the ``input`` query parameter: genom3's lenient JSON, or a readable refusal.

Strict JSON goes through orjson.  What orjson refuses goes through Python's
parser, which also takes what genom3 emits and accepts (raw control characters
in strings, ``NaN``).  That second parser has limits of its own (integers of
more than 4300 digits, nesting deeper than the recursion limit) and accepts a
lone UTF-16 surrogate (``"\ud800"``), which is no character at all: each is
refused here as bad input rather than failing later as an internal error.
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
        return orjson.loads(text)
    except orjson.JSONDecodeError:
        pass
    try:
        value = json.loads(text, strict=False)
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
