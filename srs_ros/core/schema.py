"""One schema for every config file, option table and node parameter: typed fields, one error format.

A :class:`Field` says what one key holds: its type, range, unit, description and default. A
:class:`Table` holds the fields of one mapping (a section of a YAML file, a backend's options, a node's
parameters); :meth:`Table.read` checks a mapping against it: every key known, every value of its type and
in its range, the defaults filled in. Every refusal is a :class:`~srs_ros.core.errors.ConfigurationError`
(or the error class the caller names) in one format, naming the file (or the component), the key, the
value and what is expected::

    config/sim.yaml: sim.body.segments_per_module is -2; expected an integer in [1, 20] (segments).
    config/rigs/can.yaml: rig.backend_options.bitrat is not a known key; expected one of [bitrate, ...].
    config/robot.yaml: robot.mass_kg is missing; expected a number > 0 (kg).

A file that holds one block (``sim:``, ``turning_map:``, ...) is opened with :func:`document`, which refuses
any other top-level key instead of ignoring it::

    f.yaml: the top-level key 'muscles' is not known; expected only sim: at the top ('muscles' belongs to the sim
    block: indent it under sim:).

Rules that span several keys (a timeout at least another one, a period a whole number of time steps)
stay with the code that knows them and raise through :func:`refusal`, so they read the same. A CSV table
(:func:`read_csv_rows`) is checked a row at a time by a :class:`Table`, its refusals naming file and line.
"""

from __future__ import annotations

import contextlib
import csv
import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from srs_ros.core.errors import ConfigurationError


class _Required:
    """The default of a field that must be given."""

    def __repr__(self) -> str:
        return "REQUIRED"


#: The default of a key that must be given.
REQUIRED: Any = _Required()

#: Item names of a list field, by item type.
_PLURALS = {float: "numbers", int: "integers", str: "strings", bool: "true/false values"}


def show(value: Any) -> str:
    """``value`` as a refusal prints it: ``repr`` of plain Python values (NumPy scalars as their Python value)."""
    item = getattr(value, "item", None)
    if callable(item) and getattr(value, "shape", None) == ():
        value = item()
    return repr(value)


def number_text(value: float | int) -> str:
    """A bound as people write it: ``4`` for 4.0, ``0.002``, ``1e-05``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    if isinstance(value, int):
        return str(value)
    return str(int(value)) if value.is_integer() and abs(value) < 1e16 else repr(float(value))


def refusal(where: str, key: str, value: Any, expected: str, error: type[Exception] = ConfigurationError
            ) -> Exception:
    """The one error format: ``<where>: <key> is <value>; expected <expected>.`` (raise what it returns)."""
    return error(f"{where}: {key} is {show(value)}; expected {expected}.")


def missing(where: str, key: str, expected: str, error: type[Exception] = ConfigurationError) -> Exception:
    """The refusal of a key that must be given: ``<where>: <key> is missing; expected <expected>.``."""
    return error(f"{where}: {key} is missing; expected {expected}.")


def unknown_key(where: str, key: str, known: Iterable[str], error: type[Exception] = ConfigurationError
                ) -> Exception:
    """The refusal of a key the table does not know: ``<where>: <key> is not a known key; expected one of [...]``."""
    listing = ", ".join(sorted(str(k) for k in known))
    return error(f"{where}: {key} is not a known key; expected one of [{listing}].")


def joined(path: str, name: str) -> str:
    """The dotted key of ``name`` in a mapping at ``path`` (``sim.body`` + ``skin_radius_m``)."""
    return f"{path}.{name}" if path else str(name)


def check_known(data: Mapping[str, Any], known: Iterable[str], where: str, path: str = "",
                error: type[Exception] = ConfigurationError) -> None:
    """Refuse the first key of ``data`` (in sorted order) that is not in ``known``."""
    known = set(known)
    unknown = sorted((k for k in data if k not in known), key=str)
    if unknown:
        raise unknown_key(where, joined(path, unknown[0]), known, error)


def mapping(data: Any, where: str, key: str, expected: str, error: type[Exception] = ConfigurationError
            ) -> Mapping[str, Any]:
    """``data`` if it is a mapping, else the refusal (``key`` is the mapping's own dotted key)."""
    if not isinstance(data, Mapping):
        raise refusal(where, key, data, expected, error)
    return data


def section(data: Any, name: str, where: str, path: str = "", what: str = "a mapping of key: value",
            error: type[Exception] = ConfigurationError) -> Mapping[str, Any]:
    """The mapping under ``name`` in ``data`` (at dotted ``path``); missing or not a mapping is refused."""
    key = joined(path, name)
    if not isinstance(data, Mapping) or name not in data:
        raise missing(where, key, what, error)
    return mapping(data[name], where, key, what, error)


def document(data: Any, name: str, where: str, what: str = "a mapping of key: value", sections: Iterable[str] = (),
             error: type[Exception] = ConfigurationError) -> Mapping[str, Any]:
    """The mapping under ``name``, the only top-level key of a file that holds one block (``sim:``).

    A stray top-level key is refused, not ignored: a section written at the top instead of indented under
    ``name`` (``muscles:`` beside ``sim:``) would otherwise silently have no effect. ``sections``: the keys of
    the block, named in the refusal when the stray key is one of them.
    """
    block = section(data, name, where, what=what, error=error)
    stray = sorted((k for k in data if k != name), key=str)
    if not stray:
        return block
    key = stray[0]
    hint = (f"{show(key)} belongs to the {name} block: indent it under {name}:" if key in set(sections) else
            f"move it under {name}: if it belongs there, or remove it")
    raise error(f"{where}: the top-level key {show(key)} is not known; expected only {name}: at the top ({hint}).")


def _is_bool(value: Any) -> bool:
    return isinstance(value, (bool, np.bool_))  # NumPy's bool is no int subclass, but a truth value


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not _is_bool(value)


def _is_integer(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not _is_bool(value)


@dataclass(frozen=True)
class Field:
    """One key: its type (``float``, ``int``, ``bool``, ``str``, ``list``, ``dict`` or ``object``), range, unit.

    ``minimum``/``maximum`` are inclusive (``above_minimum``: the minimum itself is refused, as for
    ``> 0``); for a ``list`` they bound every item (``item`` its type, ``length`` its exact size). A ``str``
    may be limited to ``choices``. ``default`` is :data:`REQUIRED` where the key must be given; a default
    of None makes the key optional (None, given or left out, means "not set"). ``expected`` replaces the
    generated text of what is accepted where a rule says more than a type and a range (an ``object`` field,
    checked by its owner, needs one).
    """

    name: str
    kind: type
    default: Any = REQUIRED
    minimum: float | int | None = None
    maximum: float | int | None = None
    unit: str = ""
    description: str = ""
    choices: tuple[Any, ...] = ()
    above_minimum: bool = False
    nonempty: bool = False
    item: type | None = None
    length: int | None = None
    expected_text: str = ""
    #: A value to show (``e.g. 500.0``) after what is expected.
    example: str = ""

    @property
    def required(self) -> bool:
        """True when the key must be given."""
        return self.default is REQUIRED

    # -- what is accepted ---------------------------------------------------------------------
    @property
    def expected(self) -> str:
        """What is accepted, for people: ``an integer in [1, 20] (segments)``, ``one of ['a', 'b']``."""
        text = self.expected_text or self._kind_text()
        if self.unit:
            text += f" ({self.unit})"
        return f"{text}, e.g. {self.example}" if self.example else text

    def _range_text(self) -> str:
        low = None if self.minimum is None else number_text(self.minimum)
        high = None if self.maximum is None else number_text(self.maximum)
        if low is not None and high is not None:
            return f" in {'(' if self.above_minimum else '['}{low}, {high}]"
        if low is not None:
            return f" {'>' if self.above_minimum else '>='} {low}"
        return "" if high is None else f" <= {high}"

    def _kind_text(self) -> str:
        if self.kind is bool:
            return "true or false"
        if self.kind is str:
            if self.choices:
                return f"one of {list(self.choices)}"
            return "a non-empty string" if self.nonempty else "a string"
        if self.kind is float:
            return "a number" + (self._range_text() or " (finite)")
        if self.kind is int:
            return "an integer" + self._range_text()
        if self.kind is list:
            count = f" {self.length}" if self.length is not None else ""
            return f"a list of{count} {_PLURALS.get(self.item, 'values')}{self._range_text()}"
        if self.kind is dict:
            return "a mapping of key: value"
        return "a value"

    # -- checking -----------------------------------------------------------------------------
    def convert(self, value: Any) -> tuple[bool, Any]:
        """``(True, value as the field's type)`` if ``value`` is accepted, else ``(False, None)``."""
        if value is None and self.default is None:
            return True, None
        if self.kind is list:
            return self._convert_list(value)
        return self._convert_one(value, self.kind)

    def _convert_one(self, value: Any, kind: type | None) -> tuple[bool, Any]:
        if kind is bool:
            return (True, bool(value)) if _is_bool(value) else (False, None)
        if kind is str:
            ok = isinstance(value, str) and (not self.nonempty or value != "") and (
                not self.choices or value in self.choices)
            return (True, value) if ok else (False, None)
        if kind in (float, int):
            if not (_is_integer(value) if kind is int else _is_number(value)):
                return False, None
            try:
                number = kind(value)
            except OverflowError:  # an integer of 400 digits: no float holds it (a traceback before)
                return False, None
            return (True, number) if self._in_range(number) else (False, None)
        if kind is dict:
            return (True, dict(value)) if isinstance(value, Mapping) else (False, None)
        return True, value

    def _in_range(self, number: float) -> bool:
        if not math.isfinite(number):
            return False
        if self.minimum is not None and (number < self.minimum or (self.above_minimum and number == self.minimum)):
            return False
        return self.maximum is None or number <= self.maximum

    def _convert_list(self, value: Any) -> tuple[bool, Any]:
        if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, (Sequence, Iterable)):
            return False, None
        items = list(value)
        if (self.length is not None and len(items) != self.length) or (self.nonempty and not items):
            return False, None
        converted = [self._convert_one(v, self.item) for v in items]
        if not all(ok for ok, _ in converted):
            return False, None
        return True, tuple(v for _, v in converted)

    def reason(self, value: Any, key: str | None = None) -> str:
        """'' if ``value`` is accepted, else ``<key> is <value>; expected <what>`` (no place, no full stop)."""
        ok, _ = self.convert(value)
        return "" if ok else f"{key or self.name} is {show(value)}; expected {self.expected}"

    def check(self, value: Any, where: str, key: str | None = None, error: type[Exception] = ConfigurationError
              ) -> Any:
        """``value`` converted to the field's type; :func:`refusal` (``error``) where it is not accepted."""
        ok, converted = self.convert(value)
        if not ok:
            raise refusal(where, key or self.name, value, self.expected, error)
        return converted


@dataclass(frozen=True)
class Table:
    """The fields of one mapping; ``path`` is its dotted place in the file (``sim.body``), '' at the top."""

    path: str
    fields: tuple[Field, ...]
    #: What the mapping is, for a refusal of something that is not one (``the rig``).
    description: str = ""
    _by_name: dict[str, Field] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        by_name = {f.name: f for f in self.fields}
        if len(by_name) != len(self.fields):
            raise ValueError(f"table {self.path!r} names a field twice: {[f.name for f in self.fields]}")
        object.__setattr__(self, "_by_name", by_name)

    def __getitem__(self, name: str) -> Field:
        return self._by_name[name]

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def __iter__(self):
        return iter(self.fields)

    @property
    def names(self) -> tuple[str, ...]:
        """The keys, in the table's order."""
        return tuple(self._by_name)

    @property
    def defaults(self) -> dict[str, Any]:
        """Key -> default of every key that has one."""
        return {f.name: f.default for f in self.fields if not f.required}

    def key(self, name: str) -> str:
        """The dotted key of ``name`` (``sim.body.skin_radius_m``)."""
        return joined(self.path, name)

    def at(self, path: str) -> Table:
        """The same fields at another place (``mock backend_options.per_muscle.m1_pma1``)."""
        return replace(self, path=path)

    def with_defaults(self, **defaults: Any) -> Table:
        """The same fields with other defaults (e.g. the robot's deadzone for the muscle options)."""
        unknown = set(defaults) - set(self._by_name)
        if unknown:
            raise ValueError(f"table {self.path!r} has no fields {sorted(unknown)}")
        return replace(self, fields=tuple(replace(f, default=defaults[f.name]) if f.name in defaults else f
                                          for f in self.fields))

    def only(self, names: Iterable[str]) -> Table:
        """A table of the named fields, in the table's order."""
        names = set(names)
        return replace(self, fields=tuple(f for f in self.fields if f.name in names))

    def read(self, data: Any, where: str, extra: Iterable[str] = (), error: type[Exception] = ConfigurationError
             ) -> dict[str, Any]:
        """Check ``data`` against the table: key -> converted value, defaults filled in.

        Keys in ``extra`` are the caller's own (kept out of the result, not refused). Raises ``error``
        (:class:`ConfigurationError`) for a value that is not a mapping, an unknown key, a missing required
        key or a value of the wrong type or out of range, in the format of :func:`refusal`.
        """
        what = self.description or f"a mapping with keys {list(self.names)}"
        data = mapping(data, where, self.path or "the content", what, error)
        check_known(data, (*self.names, *extra), where, self.path, error)
        values = {}
        for f in self.fields:
            key = self.key(f.name)
            if f.name in data:
                values[f.name] = f.check(data[f.name], where, key, error)
            elif f.required:
                raise missing(where, key, f.expected, error)
            else:
                values[f.name] = f.default if f.default is None else f.check(f.default, where, key, error)
        return values


def parse_assignments(items: Iterable[str], flag: str, example: str) -> dict[str, Any]:
    """``NAME=VALUE`` command-line items as {name: value}, each value read as YAML.

    As ``ros2 param set`` reads it: ``3`` an integer, ``0.5`` a number, ``true``, ``[0.1, 0.2]``, else text; the
    schema then checks each value. :class:`ConfigurationError` names ``flag`` for an item without ``=`` or a value
    YAML cannot read (``example``: what a good item looks like).
    """
    values: dict[str, Any] = {}
    for item in items:
        name, equals, text = item.partition("=")
        if not equals or not name:
            raise ConfigurationError(f"{flag} {item!r}: expected NAME=VALUE, e.g. {flag} {example}")
        try:
            value = yaml.safe_load(text) if text.strip() else text
            if isinstance(value, str):  # YAML 1.1 reads 1e-3 and 5E2 as text; a number is meant
                with contextlib.suppress(ValueError):
                    value = float(value)
            values[name] = value
        except yaml.YAMLError as exc:
            raise ConfigurationError(f"{flag} {item!r}: the value cannot be read ({str(exc).splitlines()[0]}); "
                                     f"expected a number, true/false, a [list] or text, e.g. {flag} {example}") \
                from None
    return values


def read_csv_rows(path: str | Path, table: Table, error: type[Exception] = ConfigurationError
                  ) -> list[dict[str, Any]]:
    """The rows of a CSV file whose header line names the table's keys (in any order), each checked by the table.

    A cell is read as a number where its field takes one. A refusal names the file and its line
    (``ruler.csv:3``), the column, the cell and what is expected, in the format of :func:`refusal`:
    ``ruler.csv:3: pressure_bar is '9'; expected a number in [0, 4] (bar).``
    """
    path = Path(path)
    columns = ",".join(table.names)
    if path.exists() and not path.is_file():  # a FIFO or a device would block the reader
        raise error(f"{path}: not a regular file (a directory, pipe or device); expected a CSV file {columns}.")
    try:
        with path.open(newline="", encoding="utf-8-sig") as stream:  # a spreadsheet's "CSV UTF-8" starts with a BOM
            reader = csv.reader(stream)
            header = next(reader, [])
            lines = [(reader.line_num, cells) for cells in reader if cells]
    except FileNotFoundError:
        raise error(f"{path}: no such file.") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise error(f"{path}: cannot be read as CSV ({exc}); expected a header line {columns} and a row each.") \
            from None
    if sorted(header) != sorted(table.names):
        raise refusal(str(path), "the header line", ",".join(header), f"{columns} (in any order)", error)
    return [_csv_row(header, cells, table, f"{path}:{line}", error) for line, cells in lines]


def _csv_row(header: list[str], cells: list[str], table: Table, where: str, error: type[Exception]
             ) -> dict[str, Any]:
    """One CSV row checked by ``table`` (a row of more or fewer cells than the header's columns is refused)."""
    if len(cells) != len(header):
        raise refusal(where, "the row", ",".join(cells), f"{len(header)} cells, one a column", error)
    row = dict(zip(header, cells))
    values = {}
    for f in table:
        if f.name not in row:
            raise missing(where, f.name, f.expected, error)
        text = row[f.name].strip()
        if text == "" and f.default is None:  # an optional field's empty cell: not set
            values[f.name] = None
            continue
        values[f.name] = f.check(_number(text, f.kind) if f.kind in (float, int) else text, where, error=error)
    return values


def _number(text: str, kind: type) -> Any:
    """A cell's text as ``kind`` (float or int), or the text itself where it is not one (for the refusal)."""
    try:
        return kind(text)
    except ValueError:
        return text
