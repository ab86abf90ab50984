"""Candidate surfaces for beacons, keep-out zones and the candidate grid on them.

A surface is a rectangle origin + s u + t v (s, t in [0, 1], mm). Built-in sets:

- ``module``: the six walls of the `mfns sim nav` module (a ModuleGeometry: the demo's
  4 x 2 x 2 m, or the size of --module-size), less the EDGE_MARGIN_MM strip along the
  edges the simulator also keeps clear.
- ``paper-frame``: the steel frame of the paper's navigation experiment (docs/system.md §6,
  "about 1 x 1 x 1.5 m around the turntable"), taken as the box its ten surveyed
  beacons (Table 4) span, x -460..650, y -740..410, z -70..565 mm: its four sides and
  its top; the bottom is the turntable's base and carries no LEDs.

A JSON file can give others: ``{"surfaces": [{"name": .., "origin": [3], "u": [3],
"v": [3]}], "keep_out": [{"lo": [3], "hi": [3]}]}``. Keep-out zones are boxes; no
candidate lies inside one.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.errors import MfnsError
from ..simulate.module_geom import DEMO_MODULE, EDGE_MARGIN_MM, ModuleGeometry

PAPER_FRAME_LO = np.array([-460.0, -740.0, -70.0])
PAPER_FRAME_HI = np.array([650.0, 410.0, 565.0])


@dataclass
class Surface:
    name: str
    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray


@dataclass
class KeepOut:
    lo: np.ndarray
    hi: np.ndarray

    def contains(self, p: np.ndarray) -> np.ndarray:
        return np.all((p >= self.lo) & (p <= self.hi), axis=-1)


def box_faces(lo, hi, faces: str = "xXyYzZ", prefix: str = "") -> list[Surface]:
    """Faces of an axis-aligned box: x/X = the -x/+x face, likewise y, z."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    d = hi - lo
    out = []
    for f in faces:
        ax = "xyz".index(f.lower())
        o = lo.copy()
        if f.isupper():
            o[ax] = hi[ax]
        a, b = [i for i in range(3) if i != ax]
        u, v = np.zeros(3), np.zeros(3)
        u[a], v[b] = d[a], d[b]
        out.append(Surface(f"{prefix}{'+' if f.isupper() else '-'}{'xyz'[ax]}", o, u, v))
    return out


def builtin(name: str, geom: ModuleGeometry = DEMO_MODULE) -> tuple[list[Surface], list[KeepOut]]:
    """A built-in set; geom: the module of ``module`` (the demo's by default)."""
    if name == "module":
        m = EDGE_MARGIN_MM
        walls = []
        for s in box_faces(-geom.half, geom.half, prefix="wall "):
            # shrink each wall by the edge margin inside its own plane
            du, dv = s.u / np.linalg.norm(s.u), s.v / np.linalg.norm(s.v)
            walls.append(Surface(s.name, s.origin + m * du + m * dv, s.u - 2 * m * du, s.v - 2 * m * dv))
        return walls, []
    if name == "paper-frame":
        return box_faces(PAPER_FRAME_LO, PAPER_FRAME_HI, faces="xXyYZ", prefix="frame "), []
    raise MfnsError(f"unknown surface set {name!r} (built-in: module, paper-frame; or a JSON file)")


def load(spec: str, geom: ModuleGeometry = DEMO_MODULE) -> tuple[list[Surface], list[KeepOut]]:
    """A built-in name or a JSON file (module docstring); geom: the module of ``module``."""
    if spec in ("module", "paper-frame"):
        return builtin(spec, geom)
    path = Path(spec)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError as exc:
        raise MfnsError(f"{spec}: no such surface file (built-in sets: module, paper-frame)") from exc
    except json.JSONDecodeError as exc:
        raise MfnsError(f"{spec}: not valid JSON ({exc.msg} at line {exc.lineno})") from exc
    try:
        surfaces = [
            Surface(str(s.get("name", f"surface {i}")), _vec(s["origin"]), _vec(s["u"]), _vec(s["v"]))
            for i, s in enumerate(doc["surfaces"])
        ]
        keep = [KeepOut(_vec(k["lo"]), _vec(k["hi"])) for k in doc.get("keep_out", [])]
    except (KeyError, TypeError, ValueError) as exc:
        raise MfnsError(
            f"{spec}: surfaces need origin, u, v (3 numbers each); keep_out lo, hi ({exc})"
        ) from exc
    if not surfaces:
        raise MfnsError(f"{spec}: no surfaces")
    return surfaces, keep


def _vec(x) -> np.ndarray:
    v = np.asarray(x, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{x!r} is not 3 finite numbers")
    return v


def parse_box(text: str) -> KeepOut:
    """'x0,y0,z0,x1,y1,z1' (mm) -> KeepOut."""
    try:
        v = [float(t) for t in text.split(",")]
    except ValueError as exc:
        raise MfnsError(f"--keep-out {text!r}: expected six numbers x0,y0,z0,x1,y1,z1") from exc
    if len(v) != 6 or not np.all(np.isfinite(v)):
        raise MfnsError(f"--keep-out {text!r}: expected six numbers x0,y0,z0,x1,y1,z1")
    lo, hi = np.minimum(v[:3], v[3:]), np.maximum(v[:3], v[3:])
    return KeepOut(lo, hi)


def candidates(
    surfaces: list[Surface], spacing_mm: float, keep_out: list[KeepOut]
) -> tuple[np.ndarray, np.ndarray]:
    """Grid points on the surfaces at about spacing_mm (cell centres), outside the keep-outs
    -> (points (M, 3), surface index (M,))."""
    if not spacing_mm > 0:
        raise MfnsError("--grid must be positive")
    pts, idx = [], []
    for i, s in enumerate(surfaces):
        nu = max(1, int(round(np.linalg.norm(s.u) / spacing_mm)))
        nv = max(1, int(round(np.linalg.norm(s.v) / spacing_mm)))
        a, b = np.meshgrid((np.arange(nu) + 0.5) / nu, (np.arange(nv) + 0.5) / nv, indexing="ij")
        p = s.origin + a.reshape(-1, 1) * s.u + b.reshape(-1, 1) * s.v
        pts.append(p)
        idx.append(np.full(len(p), i))
    pos, surf = np.concatenate(pts), np.concatenate(idx)
    keep = np.ones(len(pos), dtype=bool)
    for k in keep_out:
        keep &= ~k.contains(pos)
    if not keep.any():
        raise MfnsError("no candidate position left outside the keep-out zones")
    return pos[keep], surf[keep]
