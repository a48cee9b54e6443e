r"""What a name a client gives may hold: one rule for session names, recording paths and the like.

A name a client chooses travels back to people: in events, replies, logs, file listings.  Some
characters would make it lie there.  A line end or a NUL forges lines in a log or an event stream;
a bidirectional control reorders what a reader sees (``take\u202egpj.mcap`` shows as
``takepacm.jpg``), and no name needs one.  Every check of a client's name uses this one rule.
"""

from __future__ import annotations

import re
import unicodedata

__all__ = ["NAME_FORBIDDEN", "forbidden_in_name"]

#: What a client's name may not hold, as the body of a regular expression's character class:
#: control characters (C0, DEL, C1), Unicode's line and paragraph separators, and the bidirectional
#: controls (embeddings, overrides, isolates, and the marks LRM, RLM and ALM).  It is also the pattern
#: of session names in ``/openapi.json``, so that generated names are always taken.
NAME_FORBIDDEN = "\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069\u200e\u200f\u061c"
_FORBIDDEN = re.compile(f"[{NAME_FORBIDDEN}]")


def forbidden_in_name(name: str) -> str | None:
    r"""What makes *name* unfit to be a client's name, in words, or None when it is fit.

    Returns:
        For the first forbidden character: ``a control character ('\x00')``, ``a line separator
        ('\u2028')`` or ``a bidirectional control ('\u202e')``.
    """
    found = _FORBIDDEN.search(name)
    if found is None:
        return None
    character = found.group()
    if unicodedata.category(character) == "Cc":
        kind = "a control character"
    elif character in "\u2028\u2029":
        kind = "a line separator"
    else:
        kind = "a bidirectional control"
    return f"{kind} ({ascii(character)})"
