"""The command-line options of the budgets (``--max-port-bytes``...), made from the bounds' own declarations.

Each bound of :class:`~aiogenomix.components.core.Budgets` names its flag, its unit and what it
bounds; the options are made from that, so that a bound added there is an option here, with its
default in the help.  The gateway and a component host take the same options: the components hold
the same resources wherever they run.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable

from ._budgets import Budgets

__all__ = ["add_budget_arguments", "budgets_from", "parse_amount"]

_MULTIPLES = {"": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}
_AMOUNT = re.compile(r"([0-9]{1,15})\s*([kmgt]?)(i?b)?", re.IGNORECASE)


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


def _amount(unit: str) -> Callable[[str], int]:
    def parse(text: str) -> int:
        return parse_amount(text, unit)

    return parse


def add_budget_arguments(group: argparse._ArgumentGroup, defaults: Budgets) -> None:
    """Add one option per bound of :class:`Budgets` to *group*, with *defaults*."""
    for name in Budgets.names():
        unit = Budgets.unit(name)
        default = getattr(defaults, name)
        shown = str(default)
        for step, suffix in ((2**30, "G"), (2**20, "M")):
            if unit == "bytes" and default % step == 0:
                shown = f"{default // step}{suffix}"
                break
        group.add_argument(Budgets.flag(name), dest=f"budget_{name}", type=_amount(unit), default=default,
                           metavar="BYTES" if unit == "bytes" else unit.upper(),
                           help=f"{Budgets.doc(name)} (default {shown})")


def budgets_from(parser: argparse.ArgumentParser, args: argparse.Namespace) -> Budgets:
    """The :class:`Budgets` the options of *args* give (an inconsistent set is a usage error of *parser*)."""
    try:
        return Budgets(**{name: getattr(args, f"budget_{name}") for name in Budgets.names()})
    except ValueError as exc:
        parser.error(str(exc))
