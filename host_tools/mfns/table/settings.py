"""Default centroid and solver settings of the calibration table: the one definition's
(contract/caltable_layout.toml, generated into layout_gen.py; docs/caltable.md "Default
settings" gives the reasons, and the C core's nav_defaults_gen.c has the same numbers).
`mfns table build --settings FILE` overrides any of them from a JSON object
{"centroid": {...}, "solver": {...}, "integrity": {...}, "motion": {...}} (integrity: the
fault detection and exclusion settings, docs/pose.md "Integrity"; motion: the navigation
filter's motion bound, docs/caltable.md "Motion bound")."""

from __future__ import annotations

from pathlib import Path

from ..core import validate as V
from .format import CENTROID_F32, CENTROID_U16, INTEGRITY, MOTION, SOLVER_F32, SOLVER_U16
from .generated import layout_gen


def defaults() -> tuple[dict, dict]:
    """(centroid, solver) defaults, as the table stores them (f32 values in binary32)."""
    d = layout_gen.DEFAULTS["globals"]
    return (
        {k: d[f"centroid.{k}"] for k in CENTROID_U16 + CENTROID_F32},
        {k: d[f"solver.{k}"] for k in SOLVER_U16 + SOLVER_F32},
    )


MAX_BYTES = 64 * 1024
# the settings records of their own: (fields, integer fields)
_SECTIONS = {r.key: r for r in (INTEGRITY, MOTION)}
F32_MAX = 3.4028234663852886e38


def _typed(section: str, key: str, v: object) -> int | float:
    """The type the table field can carry: u16 integers, finite binary32 numbers. Ranges
    are the flight loader's to decide: `mfns table build` checks the table it writes with
    it (firmware/nav/table/caltable.c), so there is no second copy of them here."""
    name = f"{section}.{key}"
    if key in CENTROID_U16 or key in SOLVER_U16 or (section in _SECTIONS and key in _SECTIONS[section].ints):
        return V.integer(v, name, 0, 65535)
    return V.number(v, name, -F32_MAX, F32_MAX)


def load_settings(path: str | Path | None) -> tuple[dict, dict]:
    centroid, solver = defaults()
    if path is None:
        return centroid, solver
    what = f"settings {path}"
    doc = V.obj(V.load_json(path, "settings", MAX_BYTES), what)
    V.keys(doc, what, (), ("centroid", "solver", *_SECTIONS))
    for section, dst in (("centroid", centroid), ("solver", solver)):
        given = V.obj(doc.get(section, {}), f"{what}: {section}")
        V.keys(given, f"{what}: {section}", (), dst)
        for k, v in given.items():
            dst[k] = _typed(section, k, v)
    return centroid, solver


def section_defaults(section: str) -> dict:
    """The defaults of a settings record of its own ("integrity", "motion"), as the table
    stores them."""
    d = layout_gen.DEFAULTS[section]
    return {k: d[k] for k in _SECTIONS[section].names}


def load_section(path: str | Path | None, section: str) -> dict:
    """A settings record of its own ("integrity", "motion"): the defaults, overridden by
    the settings file's object of that name (ranges are the flight loader's to check)."""
    dst = section_defaults(section)
    if path is None:
        return dst
    what = f"settings {path}"
    doc = V.obj(V.load_json(path, "settings", MAX_BYTES), what)
    given = V.obj(doc.get(section, {}), f"{what}: {section}")
    V.keys(given, f"{what}: {section}", (), dst)
    for k, v in given.items():
        dst[k] = _typed(section, k, v)
    return dst
