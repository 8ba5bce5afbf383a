"""Declared options: one ``dataclasses.field`` per option carries everything said about it.

:func:`option` declares a field of a frozen settings dataclass with its type, unit, range, description and,
for a plain scalar the compiled kernels read, the name of its slot in the kernels' scalar record
(:data:`planetnav_env.kernel_params.SCALAR_FIELDS`). From those declarations come

* the checks: :func:`check_options` (called first in ``__post_init__``) raises an
  :class:`~planetnav_env.errors.OptionError` naming the option, its type, unit and range and the bad value;
  checks that involve several options stay hand-written after it;
* the option table of ``docs/environment.md`` (:func:`option_table`; ``python -m planetnav_env.config
  docs/environment.md`` rewrites it, a test keeps it equal);
* the kernel record's copied scalars (:func:`kernel_fields`, :func:`kernel_values`).

So adding an option is one declaration (and its test). ``docs/architecture.md`` ("Configuration") records
why this is in-house rather than pydantic.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterator, Sequence
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

from planetnav_env.errors import OptionError, OptionTypeError

_KEY = "planetnav_option"

#: Kinds of option value; sequences hold items of the scalar kind before the ``s``.
KINDS = ("float", "int", "bool", "str", "floats", "ints", "strs", "matrix", "section")
_ITEM = {"floats": "float", "ints": "int", "strs": "str", "matrix": "float"}

#: Markers of the generated region of a Markdown file (:func:`replace_table`).
TABLE_BEGIN = (
    "<!-- option-table: generated from the declarations by python -m planetnav_env.config; do not edit -->"
)
TABLE_END = "<!-- option-table end -->"


@dataclass(frozen=True)
class Option:
    """What one declaration says about its option (see :func:`option` for the fields)."""

    kind: str
    doc: str
    unit: str = "-"
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    choices: tuple[Any, ...] | None = None
    length: tuple[int, int | None] | None = None
    optional: bool = False
    section: type | None = None
    kernel: str | None = None

    # --- wording ------------------------------------------------------------------------------------------
    def range_text(self) -> str:
        """The allowed interval (``in (0, 1]``, ``> 0``) or choices, '' when any value of the type is."""
        if self.choices is not None:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        lo = (f"({_num(self.gt)}", f"> {_num(self.gt)}") if self.gt is not None else None
        lo = lo or ((f"[{_num(self.ge)}", f">= {_num(self.ge)}") if self.ge is not None else None)
        hi = (f"{_num(self.lt)})", f"< {_num(self.lt)}") if self.lt is not None else None
        hi = hi or ((f"{_num(self.le)}]", f"<= {_num(self.le)}") if self.le is not None else None)
        if lo and hi:
            return f"in {lo[0]}, {hi[0]}"
        return (lo or hi or ("", ""))[1]

    def length_text(self) -> str:
        lo, hi = self.length or (0, None)
        if hi == lo:
            return str(lo)
        if hi is None:
            return f"at least {lo}" if lo else "any number of"
        return f"{lo} to {hi}"

    def type_text(self) -> str:
        """The type column of the option table: ``float``, ``list[float] (3)``, ``CameraConfig or None``."""
        if self.kind == "section":
            text = self.section.__name__
        elif self.kind == "matrix":
            text = "list[list[float]] ({}x{})".format(*self.length)
        elif self.kind in _ITEM:
            text = f"list[{_ITEM[self.kind]}] ({self.length_text()})"
        else:
            text = self.kind
        return text + (" or None" if self.optional else "")

    def expected(self) -> str:
        """What an error says the value must be: ``a finite number (float, s) > 0``."""
        unit = "" if self.unit == "-" else f", {self.unit}"
        rng = self.range_text()
        rng = f" {rng}" if rng and self.choices is None else ""
        if self.kind == "section":
            text = f"{self.section.__name__} (in EnvConfig.from_dict / YAML a mapping of its options)"
        elif self.kind == "bool":
            text = "true or false (bool)"
        elif self.kind == "str":
            text = f"{self.range_text()} (str)" if self.choices is not None else "a string (str)"
        elif self.kind == "float":
            text = f"a finite number (float{unit}){rng}"
        elif self.kind == "int":
            text = f"an integer (int{unit}){rng}"
        elif self.kind == "matrix":
            text = "a {}x{} matrix of finite numbers (list of lists of float{})".format(*self.length, unit)
        else:
            item = {"float": "finite numbers", "int": "integers", "str": "names"}[_ITEM[self.kind]]
            text = f"a list of {self.length_text()} {item} ({_ITEM[self.kind]}{unit}){rng}"
        return text + (" or None" if self.optional else "")

    # --- checking -----------------------------------------------------------------------------------------
    def check(self, path: str, value: Any, coerce: bool) -> Any:
        """``value`` normalised (sequences to tuples; with ``coerce`` numbers to ``float``/``int``), or the
        :class:`OptionError` naming ``path``. Without ``coerce`` a number keeps its type (an int step stays
        an int: ``to_dict`` and the YAML written from it stay as they were)."""
        if value is None and self.optional:
            return None
        if self.kind == "section":
            if not isinstance(value, self.section):
                raise OptionTypeError(path, self.expected(), value)
            return value
        if self.kind in _ITEM:
            return self._check_sequence(path, value)
        out = self._scalar(self.kind, value)
        if out is None:
            raise OptionTypeError(path, self.expected(), value)
        if not self._in_range(out):
            raise OptionError(path, self.expected(), value)
        return out if coerce or self.kind in ("int", "bool") else value

    def _check_sequence(self, path: str, value: Any) -> tuple:
        item = _ITEM[self.kind]
        lo, hi = self.length or (0, None)
        if isinstance(value, (str, numbers.Number)):
            # One item where a list is expected (``planets="venus"``, YAML ``planets: venus``) is refused
            # rather than read as a list of one: a string is also a sequence of letters, and a rule that
            # reads some scalars as lists and not others cannot be guessed. Where a list of one is valid
            # and the item is of the right type, the error says that is what to write.
            single, hint = self._scalar(item, value), ""
            if self.kind != "matrix" and lo <= 1 and single is not None:
                noun = "name" if item == "str" else "number"
                hint = f"for a single {noun} write a one-element list: [{single!r}]"
            raise OptionTypeError(path, self.expected(), value, hint=hint)
        rows = value.tolist() if hasattr(value, "tolist") else value  # a numpy array's items as numbers
        if not isinstance(rows, (list, tuple)):
            raise OptionTypeError(path, self.expected(), value)
        if self.kind == "matrix":
            n_rows, n_cols = self.length
            if len(rows) != n_rows or not all(
                isinstance(r, (list, tuple)) and len(r) == n_cols for r in rows
            ):
                raise OptionError(path, self.expected(), value)
            out = tuple(self._scalar(item, v) for r in rows for v in r)
        else:
            out = tuple(self._scalar(item, v) for v in rows)
        if any(v is None for v in out):
            raise OptionTypeError(path, self.expected(), value)
        if self.kind != "matrix" and (len(out) < lo or (hi is not None and len(out) > hi)):
            raise OptionError(path, self.expected(), value)
        if not all(self._in_range(v) for v in out):
            raise OptionError(path, self.expected(), value)
        return tuple(zip(*[iter(out)] * self.length[1], strict=True)) if self.kind == "matrix" else out

    @staticmethod
    def _scalar(kind: str, v: Any) -> Any:
        """``v`` as ``kind`` (float, int, bool, str), or None when it is not one (bools are not numbers)."""
        if kind == "bool":
            return bool(v) if type(v).__name__ in ("bool", "bool_") else None
        if kind == "str":
            return v if isinstance(v, str) else None
        if isinstance(v, bool) or not isinstance(v, numbers.Real) or type(v).__name__ == "bool_":
            return None
        x = float(v)
        if not math.isfinite(x):
            return None if kind == "int" else x
        if kind == "int":
            return int(x) if x.is_integer() else None
        return x

    def _in_range(self, v: Any) -> bool:
        if self.choices is not None:
            return v in self.choices
        if self.kind in ("bool", "str", "strs"):
            return True
        return (
            math.isfinite(v)
            and (self.gt is None or v > self.gt)
            and (self.ge is None or v >= self.ge)
            and (self.lt is None or v < self.lt)
            and (self.le is None or v <= self.le)
        )


def option(
    default: Any,
    *,
    doc: str,
    unit: str = "-",
    kind: str | None = None,
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
    choices: Sequence[Any] | None = None,
    length: int | tuple[int, int | None] | None = None,
    kernel: str | None = None,
) -> Any:
    """A dataclass field declaring an option with its ``default``.

    ``doc``: its description (the option table's); ``unit``: its unit ('-' for none); ``kind``: one of
    :data:`KINDS`, by default that of ``default`` (a tuple or None default needs it); a None default makes
    the option optional. ``gt``/``ge``/``lt``/``le``: bounds (of every item of a sequence); ``choices``:
    the allowed values; ``length``: a sequence's length, exact or ``(min, max)`` (max None: unbounded), a
    matrix's ``(rows, cols)``; ``kernel``: the name of the slot of
    :data:`~planetnav_env.kernel_params.SCALAR_FIELDS` that holds a copy of the value (0 while an optional
    section that holds it is absent). Nested settings records are declared with :func:`section`.
    """
    kind = kind or type(default).__name__
    if kind not in KINDS or kind == "section":
        raise TypeError(f"option: kind {kind!r} is not one of {KINDS[:-1]}; declare it with kind=")
    meta = Option(
        kind=kind,
        doc=doc,
        unit=unit,
        gt=gt,
        ge=ge,
        lt=lt,
        le=le,
        choices=tuple(choices) if choices is not None else None,
        length=(length, length) if isinstance(length, int) else length,
        optional=default is None,
        kernel=kernel,
    )
    return field(default=default, metadata={_KEY: meta})


def section(cls: type, *, doc: str, optional: bool = False) -> Any:
    """A nested settings record (``camera``, ``operations``): its options are declared in ``cls``.
    ``optional``: None is allowed and is the default."""
    meta = Option(kind="section", doc=doc, optional=optional, section=cls)
    if optional:
        return field(default=None, metadata={_KEY: meta})
    return field(default_factory=cls, metadata={_KEY: meta})


def declared(cls_or_obj: Any) -> Iterator[tuple[str, Option]]:
    """(field name, :class:`Option`) of every declared option of a settings class, in declaration order."""
    for f in fields(cls_or_obj):
        opt = f.metadata.get(_KEY)
        if opt is not None:
            yield f.name, opt


def check_options(obj: Any, prefix: str, coerce: bool = False) -> None:
    """Check every declared option of the frozen dataclass ``obj`` and store its normalised value.

    ``prefix``: how errors name the options: the section's name in ``EnvConfig`` and a dot (``camera.``),
    '' for the top-level options. ``coerce``: store numbers as ``float``/``int`` (see :meth:`Option.check`).
    """
    for name, opt in declared(obj):
        value = getattr(obj, name)
        new = opt.check(prefix + name, value, coerce)
        if new is not value:
            object.__setattr__(obj, name, new)


def walk(cls: type, prefix: str = "") -> Iterator[tuple[str, Option, Any]]:
    """(dotted path, :class:`Option`, default) of every option of ``cls``, a section's own row before its
    options."""
    for f in fields(cls):
        opt = f.metadata.get(_KEY)
        if opt is None:
            continue
        default = f.default_factory() if f.default_factory is not MISSING else f.default
        yield prefix + f.name, opt, default
        if opt.kind == "section":
            yield from walk(opt.section, f"{prefix}{f.name}.")


# --- the compiled record's copies -------------------------------------------------------------------------
def kernel_fields(cls: type) -> tuple[tuple[str, str, str], ...]:
    """``(name, numpy type, meaning)`` of each kernel scalar that copies an option of ``cls``: the
    :data:`~planetnav_env.kernel_params.SCALAR_FIELDS` entries generated from the declarations."""
    return tuple(
        (opt.kernel, "i8" if opt.kind == "int" else "f8", f"{cls.__name__}.{path} [{opt.unit}]")
        for path, opt, _ in walk(cls)
        if opt.kernel is not None
    )


def kernel_values(obj: Any) -> dict[str, Any]:
    """The kernel scalars copied from the options of ``obj`` by slot name (0 for the options of an absent
    optional section)."""
    out: dict[str, Any] = {}
    for path, opt, _ in walk(type(obj)):
        if opt.kernel is not None:
            v: Any = obj
            for part in path.split("."):
                v = getattr(v, part) if v is not None else None
            out[opt.kernel] = 0 if v is None else v
    return out


# --- the option table -------------------------------------------------------------------------------------
def option_table(cls: type, prefix: str = "", elsewhere: dict[str, str] | None = None) -> str:
    """The Markdown table of every option of ``cls`` (paths after ``prefix``): name, type, default, unit,
    range, description. ``elsewhere`` maps a section's path to the page that holds its options' own table:
    that section keeps its row, which names the page, and its options are left out here."""
    elsewhere = elsewhere or {}
    rows = [
        "| option | type | default | unit | range | description |",
        "|---|---|---|---|---|---|",
    ]
    for path, opt, default in walk(cls, prefix):
        if any(path.startswith(sec + ".") for sec in elsewhere):
            continue
        below = opt.kind == "section" and default is not None
        shown = f"its options in {elsewhere[path]}" if path in elsewhere else "its options below"
        shown = shown if below else f"`{_plain(default)}`"
        rng = opt.range_text()
        if opt.kind in ("floats", "ints", "strs") and rng:
            rng = "each " + rng
        unit = "" if opt.unit == "-" else opt.unit
        cells = [f"`{path}`", opt.type_text(), shown, unit, rng, " ".join(opt.doc.split())]
        rows.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(rows) + "\n"


def replace_table(text: str, table: str) -> str:
    """``text`` (a Markdown file) with the region between :data:`TABLE_BEGIN` and :data:`TABLE_END`
    replaced by ``table``."""
    head, sep, rest = text.partition(TABLE_BEGIN + "\n")
    _, sep2, tail = rest.partition(TABLE_END)
    if not sep or not sep2:
        raise ValueError(f"no option-table region ({TABLE_BEGIN!r} ... {TABLE_END!r})")
    return head + TABLE_BEGIN + "\n" + table + TABLE_END + tail


def _plain(v: Any) -> Any:
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v


def _num(x: float) -> str:
    return repr(x) if isinstance(x, int) or not float(x).is_integer() else str(int(x))
