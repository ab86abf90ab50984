"""Each small concept of the package written once (issue 41): the CSV columns in
mfns.core.csv_formats, held here to the telemetry contract; and no module writes one of
these concepts again as a literal of its own."""

from __future__ import annotations

import ast
from pathlib import Path

from mfns.core import csv_formats as F
from mfns.tlm import tlm_dict

PKG = Path(__file__).resolve().parents[2] / "host_tools" / "mfns"


def _run_of(names: list[str], run: tuple[str, ...]) -> bool:
    """run stands in names as consecutive entries, in order."""
    return any(tuple(names[i : i + len(run)]) == run for i in range(len(names) - len(run) + 1))


def test_nav_csv_columns_are_the_nav_packets_fields():
    """nav.csv is written by mfns-ground with the names of contract/mfns_tm.xml: the pose, its
    1-sigma and its covariance columns of csv_formats are those fields, in their order."""
    names = [f.name for f in tlm_dict.load().packets["nav"].fields]
    for run in (F.POSE_COLUMNS, F.SIGMA_COLUMNS, F.COV_COLUMNS):
        assert _run_of(names, tuple(run)), f"{run} is not a run of the nav packet's fields {names}"
    assert len(F.COV_COLUMNS) == 21 and F.COV_COLUMNS[0] == "cov_x_x" and F.COV_COLUMNS[-1] == "cov_rz_rz"


def test_the_file_formats_as_the_tests_read_them():
    """The columns as the files carry them (an independent, literal check)."""
    assert F.TRUTH_HEADER == ["frame", "t_s", "x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg"]
    assert F.BEACON_COLUMNS == ("id", "x_mm", "y_mm", "z_mm", "sigma_mm")


# concept -> (its literal value, the one module that writes it)
CONCEPTS = {
    "pose columns": (("x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg"), "core/csv_formats.py"),
    "beacon columns": (("id", "x_mm", "y_mm", "z_mm", "sigma_mm"), "core/csv_formats.py"),
    "covariance axes": (("x", "y", "z", "rx", "ry", "rz"), "core/csv_formats.py"),
    "camera names": (("x", "y", "z"), "analysis/calib_results.py"),
    "calibration dataset format": ("mfns-calib-dataset", "calib/dataset.py"),
}


def _literal_assignments() -> dict[object, set[str]]:
    """Every module-level or class-level `NAME = <literal>` of the package: value -> modules."""
    out: dict[object, set[str]] = {}
    for p in PKG.rglob("*.py"):
        if "generated" in p.parts:
            continue
        for node in ast.walk(ast.parse(p.read_text())):
            if not isinstance(node, ast.Assign | ast.AnnAssign) or node.value is None:
                continue
            try:
                value = ast.literal_eval(node.value)
            except ValueError:
                continue
            if isinstance(value, list):
                value = tuple(value)
            try:
                out.setdefault(value, set()).add(str(p.relative_to(PKG)))
            except TypeError:  # unhashable (a dict, a list of lists)
                continue
    return out


def test_each_concept_is_written_once():
    found = _literal_assignments()
    wrong = {
        name: sorted(found.get(value, set()))
        for name, (value, home) in CONCEPTS.items()
        if not found.get(value, set()) <= {home}  # the home may build it from the others
    }
    assert not wrong, f"concepts written as literals elsewhere than their home: {wrong}"
