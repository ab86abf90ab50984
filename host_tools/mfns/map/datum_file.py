"""map_datum.json: the refined map's error split into what all beacons share and what each
has alone (docs/self_survey.md "Which part of the 1-sigma is the map's"), written by
`mfns map refine` beside its beacons.csv and read by `mfns table build --map-datum`.

    {"format": "mfns-map-datum-1",
     "c_w_mm": [x, y, z],                      the point the turn is about (world, mm)
     "cov": [[6 x 6]],                          over (shift x y z mm, turn x y z rad)
     "sigma_relative_mm": {"<id>": sigma, ...}, each beacon's own 1-sigma, every beacon
     "source": "..."}                           free text

The table then carries the relative sigma in its beacon records and the 6 x 6 in its map
datum section (docs/caltable.md "Map datum covariance"); the beacons.csv beside it keeps each
beacon's whole (marginal) sigma, so either file read on its own stays honest. Positive
semi-definiteness is the flight loader's check (the builder runs it on the bytes it writes).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core import validate as V
from ..core.errors import MfnsError
from ..table.format import MAP_DATUM_PARAMS, MapDatum
from ..table.generated import layout_gen as L

FORMAT = "mfns-map-datum-1"
# the table's accepted intervals (caltable_layout.toml, generated): (lo, hi, lo_open, hi_open)
_CENTRE = L.RANGE["map_datum"]["c_w"]
_SIGMA = L.RANGE["beacon"]["sigma_mm"]


def write(path: Path, ids, sigma_relative_mm, c_w_mm, cov, source: str = "") -> None:
    """Write map_datum.json (every beacon's relative sigma by id, the datum's 6 x 6)."""
    cov = np.asarray(cov, dtype=float)
    doc = {
        "format": FORMAT,
        "c_w_mm": [round(float(v), 4) for v in c_w_mm],
        "cov": [[float(v) for v in row] for row in 0.5 * (cov + cov.T)],
        "sigma_relative_mm": {
            str(int(i)): round(max(float(s), 1e-4), 4) for i, s in zip(ids, sigma_relative_mm, strict=True)
        },
        "source": source,
    }
    Path(path).write_text(json.dumps(doc, indent=1) + "\n")


def load(path, ids) -> tuple[MapDatum, np.ndarray]:
    """(datum, relative sigma per beacon in the order of ids) from map_datum.json; raises
    MfnsError (one line) unless it names exactly the beacons ids, with finite values in
    the table's ranges."""
    where = f"map datum {path}"
    d = V.obj(V.load_json(path, "map datum"), where)
    V.keys(d, where, ("format", "c_w_mm", "cov", "sigma_relative_mm"), ("source",))
    if d["format"] != FORMAT:
        raise MfnsError(f"{where}: format {d['format']!r}, expected {FORMAT!r}")
    c = V.array(d["c_w_mm"], f"{where} c_w_mm", (3,))
    lo, hi, lo_open, hi_open = _CENTRE
    if any(v < lo or v > hi or (lo_open and v == lo) or (hi_open and v == hi) for v in c):
        raise MfnsError(f"{where} c_w_mm: a coordinate beyond [{_CENTRE[0]:g}, {_CENTRE[1]:g}] mm")
    cov = V.array(d["cov"], f"{where} cov", (MAP_DATUM_PARAMS, MAP_DATUM_PARAMS))
    if not np.allclose(cov, cov.T, rtol=1e-6, atol=0.0):
        raise MfnsError(f"{where} cov: not symmetric")
    rel = V.obj(d["sigma_relative_mm"], f"{where} sigma_relative_mm")
    want = {str(int(i)) for i in ids}
    missing, extra = sorted(want - set(rel), key=int), sorted(set(rel) - want)
    if missing or extra:
        parts = ([f"lacks beacons {', '.join(missing[:8])}"] if missing else []) + (
            [f"names beacons not in the map: {', '.join(extra[:8])}"] if extra else []
        )
        raise MfnsError(f"{where}: not the map's datum: it {'; it '.join(parts)}")
    sig = np.array(
        [
            V.number(
                rel[str(int(i))],
                f"{where} sigma_relative_mm[{int(i)}]",
                _SIGMA[0],
                _SIGMA[1],
                lo_open=_SIGMA[2],
                hi_open=_SIGMA[3],
            )
            for i in ids
        ]
    )
    return MapDatum(c, cov), sig
