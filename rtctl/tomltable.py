"""Typed, path-aware access to a parsed TOML table.

Every loader (robot descriptions, run configurations) reads through :class:`Table`, so each
error names the file, the dotted key path and what was expected, and unknown keys are
refused instead of silently ignored (a typo in ``kp`` must not run the robot with a default).
"""
from __future__ import annotations

import math
import os
import re
import tomllib
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rtctl.errors import ConfigError

_MISSING = object()
ENV_TEMPLATE = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)(?::-([^}]*))?\}")  # ${VAR} or ${VAR:-default}


class _Default(Exception):
    """Raised by ``Table._get`` for an absent key: the typed readers return the default
    as given, unchecked (a default may be None, ±inf or an array)."""

    def __init__(self, value):
        self.value = value


def _default_if_absent(read):
    def wrapper(self, name, *args, **kwargs):
        try:
            return read(self, name, *args, **kwargs)
        except _Default as d:
            return d.value

    wrapper.__doc__, wrapper.__name__ = read.__doc__, read.__name__
    return wrapper


def load_toml(path) -> "Table":
    """The file's top-level Table. Not UTF-8, not TOML, unreadable, or holding a NaN or an
    infinity anywhere (TOML allows ``nan`` and ``inf``; no setting does) → ConfigError."""
    path = Path(path)
    try:
        with path.open("rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise ConfigError(path, "", "not found") from None
    except OSError as e:
        raise ConfigError(path, "", f"not readable ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise ConfigError(path, "", f"not UTF-8 text ({e})") from None
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(path, "<syntax>", f"valid TOML ({e})") from None
    _refuse_non_finite(data, path, "")
    return Table(data, path, "")


def _refuse_non_finite(value, file, key: str) -> None:
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(file, key, f"a finite number, got {value!r}")
    if isinstance(value, dict):
        for k, v in value.items():
            _refuse_non_finite(v, file, f"{key}.{k}" if key else k)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _refuse_non_finite(v, file, f"{key}[{i}]")


class Table:
    """A TOML table plus where it came from; reading a key marks it as known."""

    def __init__(self, data: dict, file, path: str):
        self.data, self.file, self.path = data, Path(file), path
        self._seen: set[str] = set()

    def key(self, name: str) -> str:
        """The key path of ``name`` in this table; the table's own for an empty name."""
        return f"{self.path}.{name}" if self.path and name else name or self.path

    def error(self, name: str, expected: str) -> ConfigError:
        return ConfigError(self.file, self.key(name), expected)

    def has(self, name: str) -> bool:
        return name in self.data

    def _get(self, name, default, expected):
        self._seen.add(name)
        if name in self.data:
            return self.data[name]
        if default is _MISSING:
            raise self.error(name, f"missing; expected {expected}")
        raise _Default(default)

    @_default_if_absent
    def str(self, name, default=_MISSING, choices=None) -> str:
        expected = f"one of {', '.join(map(repr, choices))}" if choices else "a string"
        value = self._get(name, default, expected)
        if not isinstance(value, str) or (choices and value not in choices):
            raise self.error(name, f"{expected}, got {value!r}")
        return value

    @_default_if_absent
    def bool(self, name, default=_MISSING) -> bool:
        value = self._get(name, default, "true or false")
        if not isinstance(value, bool):
            raise self.error(name, f"true or false, got {value!r}")
        return value

    @_default_if_absent
    def float(self, name, default=_MISSING, *, min=None, max=None, positive=False) -> float:
        value = self._get(name, default, "a number")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(name, f"a finite number, got {value!r}")
        self._check_range(name, value, min, max, positive)
        return float(value)

    @_default_if_absent
    def int(self, name, default=_MISSING, *, min=None, max=None) -> int:
        value = self._get(name, default, "an integer")
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(name, f"an integer, got {value!r}")
        self._check_range(name, value, min, max, False)
        return value

    def _check_range(self, name, value, lo, hi, positive):
        if positive and not value > 0:
            raise self.error(name, f"a positive number, got {value!r}")
        if lo is not None and value < lo:
            raise self.error(name, f"a number ≥ {lo}, got {value!r}")
        if hi is not None and value > hi:
            raise self.error(name, f"a number ≤ {hi}, got {value!r}")

    def vector(self, name, length=None, default=_MISSING, *, min=None, max=None) -> np.ndarray:
        """An array of finite numbers (of ``length``, if given), each within [min, max]; an
        absent key gives ``default`` as an array (None stays None)."""
        expected = f"an array of {length} numbers" if length else "an array of numbers"
        try:
            value = self._get(name, default, expected)
        except _Default as d:
            return None if d.value is None else np.array(d.value, dtype=float)
        ok = isinstance(value, list) and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in value
        )
        if not ok or (length is not None and len(value) != length):
            raise self.error(name, f"{expected}, got {value!r}")
        for i, x in enumerate(value):
            self._check_range(f"{name}[{i}]", x, min, max, False)
        return np.array(value, dtype=float)

    @_default_if_absent
    def matrix(self, name, columns: int, default=_MISSING) -> np.ndarray:
        """A non-empty array of rows, each an array of ``columns`` finite numbers → (rows, columns)."""
        expected = f"a non-empty array of arrays of {columns} numbers"
        value = self._get(name, default, expected)
        if not isinstance(value, list) or not value:
            raise self.error(name, f"{expected}, got {value!r}")
        for i, row in enumerate(value):
            if not isinstance(row, list) or len(row) != columns:
                raise self.error(f"{name}[{i}]", f"an array of {columns} numbers, got {row!r}")
            for j, x in enumerate(row):
                if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                    raise self.error(f"{name}[{i}][{j}]", f"a finite number, got {x!r}")
        return np.array(value, dtype=float)

    @_default_if_absent
    def table(self, name, default=_MISSING) -> "Table":
        value = self._get(name, default, "a table")
        if not isinstance(value, dict):
            raise self.error(name, f"a table, got {value!r}")
        return Table(value, self.file, self.key(name))

    @_default_if_absent
    def tables(self, name, default=_MISSING) -> list["Table"]:
        value = self._get(name, default, "an array of tables")
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error(name, f"an array of tables ([[{self.key(name)}]]), got {value!r}")
        return [Table(v, self.file, f"{self.key(name)}[{i}]") for i, v in enumerate(value)]

    @_default_if_absent
    def raw(self, name, default=_MISSING):
        return self._get(name, default, "a value")

    def done(self) -> None:
        """Refuse keys nobody read: they are typos or settings this version does not know."""
        unknown = sorted(set(self.data) - self._seen)
        if unknown:
            raise self.error(unknown[0], f"unknown key (known here: {', '.join(sorted(self._seen)) or 'none'})")


class Deferred(str):
    """A value whose ``${VAR}`` is not set while only checking (:func:`deferred_env`): the
    template text itself, left for the run to expand. Validators skip what they cannot know."""


@dataclass(frozen=True)
class EnvUse:
    """One ``${VAR}`` a configuration names: where, and its value here (None: unset)."""

    name: str
    file: str
    key: str
    value: str | None
    default: str | None


_env_uses: ContextVar[list | None] = ContextVar("rtctl_env_uses", default=None)


@contextmanager
def deferred_env():
    """For ``rtctl check``: inside, a ``${VAR}`` that is not set is no error — the value
    becomes a :class:`Deferred` — and every variable named is recorded. Yields the list of
    :class:`EnvUse`, filled as the configuration is read."""
    uses: list[EnvUse] = []
    token = _env_uses.set(uses)
    try:
        yield uses
    finally:
        _env_uses.reset(token)


def expand_env(t: Table, key: str, value: str, environ=os.environ):
    """``value`` with ``${VAR}`` / ``${VAR:-default}`` replaced from ``environ``; an integer
    literal obtained by expansion becomes an int. ConfigError for an unset variable without a
    default (inside :func:`deferred_env`: a :class:`Deferred` instead)."""
    uses = _env_uses.get()
    unset = []

    def sub(m):
        name, default = m.group(1), m.group(2)
        if uses is not None:
            uses.append(EnvUse(name, str(t.file), t.key(key), environ.get(name), default))
        if name in environ:
            return environ[name]
        if default is not None:
            return default
        unset.append(name)
        return m.group(0)

    expanded = ENV_TEMPLATE.sub(sub, value)
    if unset:
        if uses is not None:
            return Deferred(value)
        name = unset[0]
        raise t.error(key, f"uses ${{{name}}}, which is not set: set {name} (hil-sim prints it in its JSON line) "
                           f"or give a default, ${{{name}:-…}}")
    if expanded != value and re.fullmatch(r"[+-]?\d+", expanded.strip()):
        return int(expanded)
    return expanded
