"""Public names say where users import them from: ``__module__`` rewritten to the public module."""

from __future__ import annotations

import types
import typing
from collections.abc import Iterable, Iterator, MutableMapping
from typing import Any

__all__ = ["show_as_public"]


def show_as_public(namespace: MutableMapping[str, Any], names: Iterable[str], module: str, package: str) -> None:
    """Make ``help()`` and reprs name *module* for the *names* of *namespace* defined in *package*'s private modules.

    As httpx and our ``clients`` do.  A class's string annotations are resolved
    first, in the private module that wrote them: ``typing.get_type_hints`` looks
    names up in the module ``__module__`` names, where ``ClassVar`` or a private
    helper would be missing (a subclass's hints, such as a GenomException's
    detail members, would then fail).
    """
    for name in names:
        obj = namespace[name]
        if not str(getattr(obj, "__module__", "")).startswith(package + "._"):
            continue  # defined elsewhere (a typing alias, a public module): left alone
        if isinstance(obj, type):
            own = obj.__dict__.get("__annotations__", {})
            if any(isinstance(hint, str) for hint in own.values()):
                resolved = typing.get_type_hints(obj, include_extras=True)
                obj.__annotations__ = {key: resolved[key] for key in own}
            # Its methods too: pydoc (3.13) says "from <module>.<class>" of a method whose module differs.
            for function in _functions_of(obj):
                if function.__module__ == obj.__module__:
                    function.__module__ = module
        try:
            obj.__module__ = module
        except (AttributeError, TypeError):
            continue  # an object whose module is fixed


def _functions_of(cls: type) -> Iterator[Any]:
    """The functions a class defines: methods, class and static methods, property accessors."""
    for value in vars(cls).values():
        if isinstance(value, property):
            yield from (f for f in (value.fget, value.fset, value.fdel) if f is not None)
        elif isinstance(value, (classmethod, staticmethod)):
            yield value.__func__
        elif isinstance(value, types.FunctionType):
            yield value
