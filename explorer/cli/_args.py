"""The command line's one vocabulary: every verb adds its shared options through the ``add_*`` functions here,
so each option is spelled, parsed, defaulted and explained alike in every verb:

=========================  ==============================================================================
option                     meaning
=========================  ==============================================================================
``--top N``                how many (rows, designs, parameters); 0 = all (:func:`add_top`, :func:`top_count`)
``--variant N``            the one way to name a variant of a results file, 0 = the nominal (:func:`add_variant`)
``-o/--output PATH``       every file a verb writes, never replaced without ``--force`` (:func:`add_output`)
``--format table|csv|json`` how a verb prints a table (tables only; an export's file type comes from
                           ``-o``'s extension or ``--as``) (:func:`add_format`)
``--units model|si``       the figures in the file's model units or in SI (:func:`add_units`)
``--where EXPR``           a filter over the frame's columns (:func:`add_where`)
``--include-screened``     keep the designs the buildability screen removes (:func:`add_include_screened`)
``--seed N``               the seed of whatever a verb draws at random (:func:`add_seed`)
=========================  ==============================================================================

Old spellings (``sensitivity --plot``, ``export --format svg``, ``show RESULTS VARIANT``, ``describe --format
text``, ...) keep working for one release: :func:`add_old` adds them hidden from ``--help``, and using one prints
a one-line note on stderr naming the new spelling (:func:`old_spelling`).

Each value parser takes the text argparse hands over and returns the value, or raises a one-line
:class:`~explorer.errors.UserError` naming the option (the CLI prints it and exits 2). The options' actions
carry ``vocabulary`` (the word of the table above) so a test can check every verb speaks it.
"""

from __future__ import annotations

import argparse
import math
import sys

from ..errors import UserError

#: Output formats of the verbs that print tables (rank, sensitivity, tolerance, describe: each a subset).
FORMATS = ("table", "csv", "json")
#: The words of the vocabulary (the ``vocabulary`` attribute of the options' actions) and their options.
VOCABULARY = {"top": ("--top",), "variant": ("--variant",), "output": ("-o", "--output"), "force": ("--force",),
              "format": ("--format",), "units": ("--units",), "where": ("--where",),
              "include-screened": ("--include-screened",), "seed": ("--seed",)}


def whole(text, option: str, lo: int, note: str = "") -> int:
    """A whole number ≥ ``lo`` (``--seed``, ``--resamples``, ``--variants``); ``note`` follows the
    expectation in the message ("(0 = all)")."""
    try:
        n = int(str(text).strip())
    except ValueError:
        n = lo - 1
    if n < lo:
        raise UserError(f"{option}: expected a whole number >= {lo}{' ' + note if note else ''}, got {text!r}")
    return n


def parse_top(text) -> int | None:
    """``--top N``: rows to show; 0 = all (None)."""
    return top_count(_top_value(text), None)


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


# -- old spellings: one release with a note ------------------------------------------------------------------
def old_spelling(old: str, new: str) -> None:
    """The one-line note an old spelling prints on stderr (it still works, for one release)."""
    print(f"explorer: note: {old} is now {new}; the old spelling still works in this release only", file=sys.stderr)


class _Old(argparse.Action):
    """A hidden old spelling: it stores into the new option's ``dest`` (through ``convert``) and prints the note."""

    def __init__(self, option_strings, dest, new="", convert=None, shown=None, **kw):
        self.new, self.convert, self.shown = new, convert, shown
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        if values is None:  # an old positional not given
            return
        shown = option_string or self.shown or self.dest
        if "{}" in self.new:  # the new spelling carries the value: --format kit -> --as kit
            old_spelling(f"{shown} {values}", self.new.format(values))
        else:
            old_spelling(shown, self.new)
        setattr(namespace, self.dest, self.convert(values) if self.convert is not None else values)


def add_old(p, old: str, new: str, dest: str, convert=None, shown: str | None = None, **kw) -> None:
    """Add the hidden old spelling ``old`` of the option ``new`` (``dest`` as the new one's); ``convert`` turns its
    value into the new one's (a whole number, ...). A positional old spelling: ``old`` without dashes."""
    if old.startswith("-"):
        p.add_argument(old, dest=dest, action=_Old, new=new, convert=convert, help=argparse.SUPPRESS, **kw)
    else:
        p.add_argument(old, action=_Old, new=new, convert=convert, help=argparse.SUPPRESS, nargs="?", default=None,
                       shown=shown or old, **kw)


def _tag(action, word: str):
    action.vocabulary = word
    return action


class _Convert(argparse.Action):
    """An option whose text is parsed into its value as it is read (a one-line UserError when it is wrong)."""

    def __init__(self, option_strings, dest, convert=None, **kw):
        self.convert = convert
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        if isinstance(values, list):
            setattr(namespace, self.dest, [self.convert(v) for v in values])
        else:
            setattr(namespace, self.dest, self.convert(values))


# -- --top N ------------------------------------------------------------------------------------------------
def _top_value(text) -> int:
    return whole(text, "--top", 0, "(0 = all)")


def add_top(p, what: str, default: str) -> None:
    """``--top N`` (0 = all): ``what`` it counts, ``default`` says the default in words. Read back with
    :func:`top_count`."""
    _tag(p.add_argument("--top", metavar="N", default=None, action=_Convert, convert=_top_value,
                        help=f"{what} (default: {default}; 0 = all)"), "top")


def top_count(value: int | None, default: int | None) -> int | None:
    """``--top``'s count: ``default`` when it was not given; None for all (0)."""
    n = default if value is None else value
    return None if n is None or n == 0 else n


# -- --variant N --------------------------------------------------------------------------------------------
def _variant_value(text) -> int:
    return whole(text, "--variant", 0, "(a variant; 0 = the nominal)")


def add_variant(p, help: str, *, many: bool = False, dest: str = "variant") -> None:
    """``--variant N`` (``many``: ``--variant N [N ...]``), the one way to name a variant of a results file.
    The value is a whole number >= 0 (the range is checked against the file: :func:`parse_variant`)."""
    _tag(p.add_argument("--variant", dest=dest, metavar="N", default=None, action=_Convert, convert=_variant_value,
                        nargs="+" if many else None, help=help), "variant")


def add_vs(p, help: str) -> None:
    """``--vs N``: the reference design a verb compares with, a variant as --variant names one (default 0)."""
    p.add_argument("--vs", metavar="N", default=0, action=_Convert, convert=_variant_value, help=help)


def add_old_positional_variant(p) -> None:
    """The old positional VARIANT (``explorer show RESULTS 3``): it works, with the note to say --variant 3."""
    add_old(p, "old_variant", "--variant N", dest="old_variant", shown="a positional VARIANT")


def chosen_variant(args, verb: str, usage: str) -> int:
    """The variant of :func:`add_variant` (or the old positional VARIANT): UserError if both are given and
    differ, or neither is."""
    old = getattr(args, "old_variant", None)
    if old is not None:
        old = _variant_value(old)
        if args.variant is not None and args.variant != old:
            raise UserError(f"{verb}: two different variants given ({old} and --variant {args.variant})")
    chosen = args.variant if args.variant is not None else old
    if chosen is None:
        raise UserError(f"{verb}: say which variant: {usage}")
    return chosen


# -- -o/--output PATH and --force -------------------------------------------------------------------------
def add_output(p, help: str, *, required: bool = False, default=None, force: str | None = None,
               group=None, metavar: str = "PATH") -> None:
    """``-o/--output PATH`` (the file a verb writes) and ``--force`` (replace it; never done without it).
    ``force`` overrides --force's help; ``group``: a mutually exclusive group for --force (run's --resume)."""
    _tag(p.add_argument("-o", "--output", metavar=metavar, default=default, required=required, help=help), "output")
    add_force(group if group is not None else p, force)


def add_force(p, help: str | None = None) -> None:
    """``--force``: replace what the verb writes where it exists (never done without it)."""
    _tag(p.add_argument("--force", action="store_true",
                        help=help or "overwrite the output if it exists (never done without it)"), "force")


# -- --format table|csv|json -----------------------------------------------------------------------------
def add_format(p, formats=FORMATS, what: str = "", old: dict | None = None) -> None:
    """``--format`` of a verb that prints a table: one of ``formats`` (a subset of :data:`FORMATS`, table first
    and the default); ``what`` adds to the help; ``old`` maps old values to new ones (a note when used)."""
    old = dict(old or {})

    def convert(text):
        if text in old:
            old_spelling(f"--format {text}", f"--format {old[text]}")
            return old[text]
        return check_format(text, formats)

    _tag(p.add_argument("--format", metavar="|".join(formats), default="table", action=_Convert, convert=convert,
                        help=f"{', '.join(formats[:-1])} or {formats[-1]}: how the table is printed (default: table, "
                             f"aligned for reading{'; ' + what if what else ''})"), "format")


# -- --units, --where, --include-screened, --seed ---------------------------------------------------------
def add_units(p, what: str = "") -> None:
    """The ``--units model|si`` option of a verb that prints or draws a results file's figures."""
    _tag(p.add_argument("--units", choices=("model", "si"), default="model",
                        help="model (default: the file's own units) or si: lengths in mm, travel in m per turn, the "
                             "walking speed in m/s at the study's rpm, the torque metrics in N·m with its load "
                             "(needs the study's [operating] unit, metres per model unit). Ranks and filters stay "
                             "over the stored values" + (f"; {what}" if what else "")), "units")


def add_where(p, what: str = "") -> None:
    """``--where EXPR``: a filter over the frame's columns, parsed by the restricted grammar (never Python)."""
    _tag(p.add_argument("--where", metavar="EXPR", default=None,
                        help="filter, e.g. \"bob < 0.2 and slip < 0.01\": columns, numbers, comparisons, + - * /, "
                             "and/or/not, in [...], `backticks` for names such as `1-3`; never run as Python"
                             + (f" ({what})" if what else "")), "where")


def add_include_screened(p, what: str = "") -> None:
    """``--include-screened``: keep the ok designs the buildability screen removes."""
    _tag(p.add_argument("--include-screened", action="store_true",
                        help="keep the ok variants the buildability screen removes (the screen column says why)"
                             + (f"; {what}" if what else "")), "include-screened")


def add_seed(p, default: int, what: str) -> None:
    """``--seed N``: a whole number >= 0, the seed of ``what``."""
    _tag(p.add_argument("--seed", metavar="N", default=default, action=_Convert,
                        convert=lambda text: whole(text, "--seed", 0),
                        help=f"seed of {what} (default {default})"), "seed")


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
