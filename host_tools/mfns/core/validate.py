"""Checked reading of user inputs: one place for the rules every reader of the host tools
follows (files, JSON, CSV, typed values).

- A file is read only when it is a regular file no larger than the reader's limit
  (`/dev/zero`, a FIFO or a directory are refused before any byte is read), and the
  read itself is bounded (a file that grows meanwhile is still refused).
- JSON: strict (no NaN/Infinity constants, no duplicate keys); a document nested
  beyond the parser's recursion limit is a clear error, never a RecursionError.
- Values: a bool is not a number, a float is not an integer, a string is not a
  number, every number is finite; shapes and ranges are checked with the field's name.

Every failure raises MfnsError with one line naming the file and the field; the
`mfns` command prints it and exits with status 2.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import stat
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from .errors import MfnsError

KIB = 1024
MIB = 1024 * KIB


# ---- files -----------------------------------------------------------------------------
def read_bytes(path: str | os.PathLike, what: str, max_bytes: int) -> bytes:
    """The bytes of a regular file of at most max_bytes, else MfnsError. Opened without
    blocking and checked on the open descriptor, so a FIFO or device swapped in after a
    check can neither block nor be read."""
    p = Path(path)
    try:
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        raise MfnsError(f"{what} not found: {p}") from None
    except OSError as exc:
        raise MfnsError(f"{what} {p}: {exc.strerror or exc}") from exc
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_size > max_bytes:
        os.close(fd)
        if not stat.S_ISREG(st.st_mode):
            raise MfnsError(f"{what} {p}: not a regular file")
        raise MfnsError(f"{what} {p}: {st.st_size} bytes, larger than the limit of {max_bytes} bytes")
    with os.fdopen(fd, "rb") as f:
        try:
            data = f.read(max_bytes + 1)
        except OSError as exc:
            raise MfnsError(f"{what} {p}: {exc.strerror or exc}") from exc
    if len(data) > max_bytes:
        raise MfnsError(f"{what} {p}: larger than the limit of {max_bytes} bytes")
    return data


def read_text(path: str | os.PathLike, what: str, max_bytes: int) -> str:
    data = read_bytes(path, what, max_bytes)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise MfnsError(f"{what} {path}: not UTF-8 text (byte {exc.start})") from exc


# ---- JSON ------------------------------------------------------------------------------
def _no_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def _no_duplicates(pairs: list[tuple[str, object]]) -> dict:
    out: dict = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(f"duplicate key {k!r}")
        out[k] = v
    return out


def parse_json(text: str, what: str) -> object:
    try:
        return json.loads(text, parse_constant=_no_constant, object_pairs_hook=_no_duplicates)
    except json.JSONDecodeError as exc:
        raise MfnsError(f"{what}: not valid JSON ({exc.msg} at line {exc.lineno})") from exc
    except RecursionError:
        raise MfnsError(f"{what}: JSON nested too deeply") from None
    except ValueError as exc:
        raise MfnsError(f"{what}: not valid JSON ({exc})") from exc


def load_json(path: str | os.PathLike, what: str, max_bytes: int = 4 * MIB) -> object:
    return parse_json(read_text(path, what, max_bytes), f"{what} {path}")


# ---- CSV -------------------------------------------------------------------------------
def read_csv(
    path: str | os.PathLike, what: str, required: Iterable[str], max_bytes: int = 64 * MIB
) -> list[dict[str, str]]:
    """Rows of a CSV with a header holding every required column; every row complete."""
    text = read_text(path, what, max_bytes)
    if "\0" in text:
        raise MfnsError(f"{what} {path}: holds a NUL byte")
    try:
        reader = csv.DictReader(io.StringIO(text, newline=""))
        header = reader.fieldnames or []
        missing = [c for c in required if c not in header]
        if missing:
            raise MfnsError(f"{what} {path}: missing columns {', '.join(missing)} (header {header})")
        rows = []
        for r in reader:
            if None in r or any(v is None for v in r.values()):
                raise MfnsError(f"{what} {path}: line {reader.line_num}: wrong number of fields")
            rows.append(r)
    except csv.Error as exc:
        raise MfnsError(f"{what} {path}: not a CSV ({exc})") from exc
    return rows


def csv_float(text: str, name: str) -> float:
    """A finite number written in a CSV field."""
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise MfnsError(f"{name}: {text!r} is not a number") from None
    if not math.isfinite(v):
        raise MfnsError(f"{name}: {text!r} is not finite")
    return v


def csv_int(text: str, name: str, lo: int, hi: int) -> int:
    """An integer written in a CSV field (digits only: '3.7' and '3.0' are refused)."""
    t = text.strip() if isinstance(text, str) else text
    if not isinstance(t, str) or not t.lstrip("+-").isdigit() or not t.isascii():
        raise MfnsError(f"{name}: {text!r} is not an integer")
    v = int(t)
    if not lo <= v <= hi:
        raise MfnsError(f"{name}: {v} outside {lo}..{hi}")
    return v


# ---- typed values of a parsed document -------------------------------------------------
def _show(v: object) -> str:
    if isinstance(v, list):
        return f"a list of {len(v)}"
    if isinstance(v, dict):
        return "an object"
    s = json.dumps(v) if isinstance(v, (bool, int, float, str, type(None))) else type(v).__name__
    return s if len(s) <= 40 else s[:37] + "..."


def obj(v: object, name: str) -> dict:
    if not isinstance(v, dict):
        raise MfnsError(f"{name}: expected a JSON object, got {_show(v)}")
    return v


def keys(d: dict, name: str, required: Iterable[str] = (), optional: Iterable[str] | None = None) -> None:
    """Every required key present; with optional given, no key outside required + optional."""
    required = tuple(required)
    missing = [k for k in required if k not in d]
    if missing:
        raise MfnsError(f"{name}: missing {', '.join(map(repr, missing))}")
    if optional is not None:
        extra = sorted(set(d) - set(required) - set(optional))
        if extra:
            raise MfnsError(f"{name}: unknown key(s) {', '.join(map(repr, extra))}")


def number(v: object, name: str, lo: float | None = None, hi: float | None = None, *,
           lo_open: bool = False, hi_open: bool = False) -> float:  # fmt: skip
    """A finite JSON number (int or float, never a bool) within [lo, hi] (or open ends)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise MfnsError(f"{name}: expected a number, got {_show(v)}")
    f = float(v) if not isinstance(v, int) or abs(v) < 2**1000 else math.inf
    if not math.isfinite(f):
        raise MfnsError(f"{name}: expected a finite number, got {_show(v)}")
    if lo is not None and (f < lo or (lo_open and f == lo)):
        raise MfnsError(f"{name}: {f:g} below {'(' if lo_open else '['}{lo:g}, ...")
    if hi is not None and (f > hi or (hi_open and f == hi)):
        raise MfnsError(f"{name}: {f:g} above ..., {hi:g}{')' if hi_open else ']'}")
    return f


def integer(v: object, name: str, lo: int, hi: int) -> int:
    """A JSON integer (not a bool, not 3.0) within lo..hi."""
    if isinstance(v, bool) or not isinstance(v, int):
        raise MfnsError(f"{name}: expected an integer, got {_show(v)}")
    if not lo <= v <= hi:
        raise MfnsError(f"{name}: {v} outside {lo}..{hi}")
    return v


def string(v: object, name: str) -> str:
    if not isinstance(v, str):
        raise MfnsError(f"{name}: expected a string, got {_show(v)}")
    return v


def array(v: object, name: str, shape: tuple[int, ...]) -> np.ndarray:
    """A nested JSON list of finite numbers of exactly this shape, as float64."""

    def walk(x: object, dims: tuple[int, ...], where: str) -> float | list:
        if not dims:
            return number(x, where)
        if not isinstance(x, list) or len(x) != dims[0]:
            n = f"{len(x)} entries" if isinstance(x, list) else _show(x)
            raise MfnsError(f"{where}: expected a list of {dims[0]}, got {n}")
        return [walk(e, dims[1:], f"{where}[{i}]") for i, e in enumerate(x)]

    return np.array(walk(v, shape, name), dtype=float).reshape(shape)
