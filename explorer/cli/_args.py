"""Argument types shared by the verbs: one parser per kind of value, so every verb reads ``--top``,
``--weights``, a variant number or a whole number the same way and says the same thing when it is wrong.

Each parser takes the text argparse hands over and returns the value, or raises a one-line
:class:`~explorer.errors.UserError` naming the option (the CLI prints it and exits 2).
"""

from __future__ import annotations

import math

from ..errors import UserError

#: Output formats of the verbs that print tables (rank, sensitivity).
FORMATS = ("table", "csv", "json")


def whole(text, option: str, lo: int) -> int:
    """A whole number ≥ ``lo`` (``--seed``, ``--resamples``, ``--variants``)."""
    try:
        n = int(str(text).strip())
    except ValueError:
        n = lo - 1
    if n < lo:
        raise UserError(f"{option}: expected a whole number >= {lo}, got {text!r}")
    return n


def parse_top(text) -> int | None:
    """``--top N``: rows to show; 0 = all (None)."""
    try:
        n = int(str(text).strip())
    except ValueError:
        n = -1
    if n < 0:
        raise UserError(f"--top: expected a whole number >= 0 (0 = all), got {text!r}")
    return None if n == 0 else n


def parse_list(text, option: str) -> list[str]:
    """Comma-separated names (``--pareto travel,bob``, ``--columns``)."""
    names = [s.strip() for s in str(text).split(",") if s.strip()]
    if not names:
        raise UserError(f"{option}: expected comma-separated names, got {text!r}")
    return names


def parse_weights(text) -> dict[str, float]:
    """``--weights travel=2,bob=1`` → {metric: weight}."""
    out: dict[str, float] = {}
    for item in parse_list(text, "--weights"):
        name, sep, value = item.partition("=")
        name = name.strip()
        try:
            w = float(value) if sep else math.nan
        except ValueError:
            w = math.nan
        if not name or not math.isfinite(w):
            raise UserError(f"--weights: expected METRIC=WEIGHT pairs such as stride=2,flatness=1, got {item!r}")
        if name in out:
            raise UserError(f"--weights: {name!r} is given twice")
        out[name] = w
    return out


def check_format(text, formats=FORMATS) -> str:
    """``--format``: one of ``formats``."""
    if text not in formats:
        raise UserError(f"--format: expected one of {', '.join(formats)}, got {text!r}")
    return text


# -- the variant of a results file ------------------------------------------------------------------------
def add_variant_arguments(p, how: str) -> None:
    """The variant of a RESULTS file, given either as the positional VARIANT or as --variant N (``how``
    says which other verbs take it that way); read back with :func:`chosen_variant`."""
    p.add_argument("variant", metavar="VARIANT", nargs="?", default=None,
                   help="variant number, 0 to N-1 (0 = the nominal design); or give it as --variant N")
    p.add_argument("--variant", dest="variant_opt", metavar="N", default=None, help=f"the variant, {how}")


def chosen_variant(args, verb: str, usage: str) -> str:
    """The variant text of :func:`add_variant_arguments` (UserError if both forms differ, or neither is given)."""
    if args.variant is not None and args.variant_opt is not None and args.variant != args.variant_opt:
        raise UserError(f"{verb}: two different variants given ({args.variant} and --variant {args.variant_opt})")
    chosen = args.variant if args.variant is not None else args.variant_opt
    if chosen is None:
        raise UserError(f"{verb}: say which variant: {usage}")
    return chosen


def parse_variant(text, n: int, filename) -> int:
    """A variant number of a results file of ``n`` variants."""
    try:
        v = int(str(text).strip())
    except ValueError:
        raise UserError(f"{filename}: variant: expected a whole number from 0 to {n - 1}, got {text!r}") from None
    if not 0 <= v < n:
        raise UserError(f"{filename}: variant {v} out of range (0 to {n - 1}: {n:,} variants)")
    return v


# -- the file a verb writes: the one output policy, at home in explorer._files (the library's writers use it too)
from .._files import output_path  # noqa: E402,F401
