"""Settings groups: each setting declared once, with its default, flag, unit, help and refusal.

A settings group is a frozen dataclass that derives from :class:`SettingsGroup` and declares its
fields with :func:`setting`::

    @dataclasses.dataclass(frozen=True)
    class EarsSettings(SettingsGroup, section="ears", about="the ears of another package"):
        gain: float = setting(0.0, flag="--ears-gain", unit="dB", help="gain of the ears",
                              refuse=at_least(-40.0))

Everything else is made from that declaration: the command-line option (in the ``--help`` section
the group names, its default shown), its parsing, and the refusal of a bad value, both on the
command line (a usage error naming the flag) and in code (a :class:`ValueError` naming the flag,
raised by the group's ``__post_init__``).  A field declared without :func:`setting` has no flag:
code sets it (the address of the dedicated socket, derived from the gateway's ``--host``).

The gateway and a component host build their command lines from their groups; groups of other
packages arrive through the ``aiogenomix.settings`` entry points (:func:`installed_settings_groups`)
and reach their components as ``self.host.settings.of(EarsSettings)``.
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.metadata
import math
import os
import re
from collections.abc import Callable, Iterable
from typing import Any, ClassVar, TypeVar, cast

__all__ = [
    "Setting", "SettingsGroup", "setting", "declared_settings", "add_settings_arguments", "settings_from",
    "at_least", "positive", "whole_at_least", "tcp_port", "parse_amount", "amount_text", "installed_settings_groups",
    "SETTINGS_ENTRY_POINTS",
]

T = TypeVar("T")
G = TypeVar("G", bound="SettingsGroup")

#: The entry point group through which other packages add settings groups (and so flags).
SETTINGS_ENTRY_POINTS = "aiogenomix.settings"
_KEY = "aiogenomix.setting"
_MULTIPLES = {"": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}
_AMOUNT = re.compile(r"([0-9]{1,15})\s*([kmgt]?)(i?b)?", re.IGNORECASE)
#: The placeholder of a value in ``--help`` for each unit (else the flag's name, as argparse does).
_METAVARS = {"seconds": "SECONDS", "bytes": "BYTES"}


@dataclasses.dataclass(frozen=True)
class Setting:
    """The declaration of one setting besides its default (see :func:`setting`)."""

    flag: str
    help: str
    unit: str = ""
    metavar: str | None = None
    parse: Callable[[str], Any] | None = None
    refuse: Callable[[Any], str | None] | None = None
    env: str | None = None
    shown: str | None = None
    repeatable: bool = False


def setting(default: T, *, flag: str, help: str, unit: str = "", metavar: str | None = None,
            parse: Callable[[str], Any] | None = None, refuse: Callable[[Any], str | None] | None = None,
            env: str | None = None, shown: str | None = None, repeatable: bool | None = None) -> T:
    """Declare a field of a settings group: its default and everything its flag needs.

    Args:
        default: The value when neither code nor the command line gives one.  A tuple makes a
            repeatable flag (each use adds one value); a bool a switch (``store_true``).
        flag: The command-line option (``--ears-gain``).
        help: What it sets, in a few words (``--help`` adds the default and the unit).
        unit: What the number counts (``seconds``, ``bytes``, ``dB``...): shown in ``--help``.
        metavar: The value's placeholder in ``--help`` (default from the unit or the flag).
        parse: Turns the flag's text into the value (default: the type of *default*).
        refuse: Says why a value is refused (``"takes 1 or more"``), or None when it is accepted;
            applied to the command line and to values given in code alike.
        env: An environment variable that gives the flag's default (a token, kept out of ``ps``).
        shown: How the default reads in ``--help`` (``"none: no view"``).
        repeatable: Whether each use of the flag adds a value (default: when *default* is a tuple);
            the values given are kept as a tuple.

    Returns:
        The dataclass field (typed as the value, so that ``gain: float = setting(0.0, ...)`` checks).
    """
    declared = Setting(flag, help, unit, metavar, parse, refuse, env, shown,
                       isinstance(default, tuple) if repeatable is None else repeatable)
    return dataclasses.field(default=default, metadata={_KEY: declared})


class SettingsGroup:
    """The base of a settings group: a frozen dataclass whose fields are declared with :func:`setting`.

    Subclasses name the ``--help`` section of their flags (``section=``, and ``about=`` says what the
    section is); groups that name the same section share it.  Values given in code are refused as
    on the command line: ``__post_init__`` raises :class:`ValueError` naming the flag (a subclass
    that checks more calls ``super().__post_init__()``).  A list given for a setting is kept as a
    tuple, so that the group stays frozen all the way down.
    """

    section: ClassVar[str] = "settings"
    about: ClassVar[str] = ""

    def __init_subclass__(cls, section: str = "", about: str = "", **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if section:
            cls.section, cls.about = section, about

    def __post_init__(self) -> None:
        for field, declared in declared_settings(type(self)):
            value = getattr(self, field.name)
            if isinstance(value, list):
                object.__setattr__(self, field.name, value := tuple(value))
            reason = None if declared.refuse is None else declared.refuse(value)
            if reason is not None:
                raise ValueError(f"{field.name} ({declared.flag}) {reason}, not {value!r}")


def declared_settings(group: type[SettingsGroup]) -> list[tuple[dataclasses.Field[Any], Setting]]:
    """The fields of *group* declared with :func:`setting`, in declaration order, with their declarations."""
    fields: tuple[dataclasses.Field[Any], ...] = dataclasses.fields(cast(Any, group))
    return [(f, f.metadata[_KEY]) for f in fields if _KEY in f.metadata]


# -- refusals -------------------------------------------------------------------------------------

def at_least(low: float) -> Callable[[Any], str | None]:
    """The refusal of a number below *low* (NaN too)."""

    def refuse(value: Any) -> str | None:
        number = value if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan
        return None if number >= low else f"takes a number, {low:g} or more"

    return refuse


def positive(value: Any) -> str | None:
    """The refusal of a number that is not above 0 (NaN too)."""
    number = value if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan
    return None if number > 0 else "takes a positive number"


def whole_at_least(low: int) -> Callable[[Any], str | None]:
    """The refusal of anything but a whole number, *low* or more."""

    def refuse(value: Any) -> str | None:
        whole = isinstance(value, int) and not isinstance(value, bool)
        return None if whole and value >= low else f"takes a whole number, {low} or more"

    return refuse


def tcp_port(value: Any) -> str | None:
    """The refusal of anything but a TCP port (0, a free one, to 65535); None passes (no port)."""
    if value is None or isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= 65535:
        return None
    return "takes a TCP port (0 to 65535)"


def parse_amount(text: str, unit: str = "bytes") -> int:
    """A whole amount, 1 or more; in bytes also with a binary multiple: ``64M``, ``64MiB``, ``1G``.

    Raises:
        argparse.ArgumentTypeError: for anything else (Unicode digits, fractions, 0).
    """
    match = _AMOUNT.fullmatch(text.strip())
    with_multiple = match is not None and bool(match.group(2) or match.group(3))
    if match is None or (with_multiple and unit != "bytes"):
        example = "64M, 1G or a number of bytes" if unit == "bytes" else f"a number of {unit}"
        raise argparse.ArgumentTypeError(f"{text!r} is not an amount ({example})")
    value = int(match.group(1)) * _MULTIPLES[match.group(2).lower()]
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: at least 1")
    return value


def amount_text(amount: int, unit: str) -> str:
    """An amount as a flag takes it: ``64M``, ``1G`` for bytes in whole binary multiples, else the number."""
    for step, suffix in ((2**30, "G"), (2**20, "M")):
        if unit == "bytes" and amount and amount % step == 0:
            return f"{amount // step}{suffix}"
    return str(amount)


# -- the command line -----------------------------------------------------------------------------

def _dest(group: type[SettingsGroup], name: str) -> str:
    return f"{group.__module__}.{group.__qualname__}.{name}"


def _parser_of(field: dataclasses.Field[Any], declared: Setting) -> Callable[[str], Any]:
    """The argparse type of a setting: its parser, then its refusal (a usage error naming the flag)."""
    default = field.default
    parse: Callable[[str], Any]
    if declared.parse is not None:
        parse = declared.parse
    elif isinstance(default, (int, float)) and not isinstance(default, bool):
        parse = type(default)
    else:
        parse = str

    def typed(text: str) -> Any:
        try:
            value = parse(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {_article(parse)}") from None
        reason = None if declared.refuse is None or declared.repeatable else declared.refuse(value)
        if reason is not None:
            raise argparse.ArgumentTypeError(f"{reason}, not {text}")
        return value

    return typed


def _article(parse: Callable[[str], Any]) -> str:
    if parse is int:
        return "a whole number"
    return "a number" if parse is float else "a value it takes"


def _help(declared: Setting, default: Any) -> str:
    """The help of a setting's option: its words, and its default (the placeholder names the unit)."""
    if declared.shown is not None:
        text = f"{declared.help} (default {declared.shown})"
    elif default is None or default is False or default == () or "(default" in declared.help:
        text = declared.help
    else:
        shown = amount_text(default, declared.unit) if isinstance(default, int) else str(default)
        text = f"{declared.help} (default {shown})"
    return text.replace("%", "%%")   # (argparse formats help with %)


def _add_one(section: argparse._ArgumentGroup, group: type[SettingsGroup], field: dataclasses.Field[Any],
             declared: Setting, default: Any) -> None:
    dest = _dest(group, field.name)
    text = _help(declared, default)
    if isinstance(field.default, bool):
        section.add_argument(declared.flag, dest=dest, action="store_true", default=default, help=text)
        return
    metavar = declared.metavar or _METAVARS.get(declared.unit) or declared.flag.lstrip("-").replace("-", "_").upper()
    if declared.repeatable:
        section.add_argument(declared.flag, dest=dest, action="append", type=_parser_of(field, declared),
                             default=None, metavar=metavar, help=text)
        return
    if declared.env is not None:
        default = os.environ.get(declared.env, default)
    section.add_argument(declared.flag, dest=dest, type=_parser_of(field, declared), default=default,
                         metavar=metavar, help=text)


def add_settings_arguments(parser: argparse.ArgumentParser, defaults: Iterable[SettingsGroup]) -> None:
    """Add the options of every setting of *defaults*' groups to *parser*, with those values as defaults.

    Groups that name the same section share one ``--help`` section, in the order they come.
    """
    sections: dict[str, argparse._ArgumentGroup] = {}
    for values in defaults:
        group = type(values)
        section = sections.get(group.section)
        if section is None:
            section = sections[group.section] = parser.add_argument_group(group.section, group.about or None)
        for field, declared in declared_settings(group):
            _add_one(section, group, field, declared, getattr(values, field.name))


def settings_from(parser: argparse.ArgumentParser, args: argparse.Namespace, defaults: G, **derived: Any) -> G:
    """The group of *defaults*' class that the options of *args* give (a refusal is a usage error of *parser*).

    Args:
        parser: The parser that parsed *args* (for its usage error).
        args: Its parsed arguments.
        defaults: The group whose values stand where an option was not given (a repeatable one
            given adds to nothing: the command line says all of it).
        derived: Fields set by the caller (a field without a flag, or one another flag implies).
    """
    group = type(defaults)
    values = dict(derived)
    for field, _ in declared_settings(group):
        given = getattr(args, _dest(group, field.name), None)
        if field.name not in values:
            values[field.name] = tuple(given) if isinstance(given, list) else (
                getattr(defaults, field.name) if given is None else given)
    try:
        return cast(G, dataclasses.replace(cast(Any, defaults), **values))
    except ValueError as exc:
        parser.error(str(exc))


def installed_settings_groups() -> list[type[SettingsGroup]]:
    """The settings groups other packages declare through the ``aiogenomix.settings`` entry points.

    Raises:
        TypeError: for an entry point that cannot be loaded, or names something other than a settings group.
    """
    groups: list[type[SettingsGroup]] = []
    for entry in importlib.metadata.entry_points(group=SETTINGS_ENTRY_POINTS):
        try:
            found = entry.load()
        except (ImportError, AttributeError) as exc:
            raise TypeError(f"the {SETTINGS_ENTRY_POINTS} entry point {entry.name} ({entry.value}) cannot be "
                            f"loaded: {exc}") from exc
        if not (isinstance(found, type) and issubclass(found, SettingsGroup) and dataclasses.is_dataclass(found)):
            raise TypeError(f"the {SETTINGS_ENTRY_POINTS} entry point {entry.name} ({entry.value}) is not a "
                            "settings group: a frozen dataclass deriving from SettingsGroup")
        groups.append(found)
    return groups
