"""The fix record end to end (issue 29, docs/self_survey.md section 1): the host-sim flight
program `mfns-nav --fixlog DIR` writes the on-board log, the ground's Python reader
(mfns.map.fixlog) reads it back, and what it reads is checked against the same run's
telemetry as mfns-ground decodes it (nav.csv): the same usable cycles, the same poses, and
associations that project where the fix's pose says. Rotation: with small files
(`--fixlog-rotate KB,FILES`) the log keeps at most FILES files of at least KB kB (the last
excepted), cut at record boundaries, the newest fixes whole, and a restart continues the numbering.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from flight_replay import fly_replay  # tests/host

from mfns.map import fixlog
from mfns.model.camera import load_beacons, pose_from_position, rig_from_doc
from mfns.model.rotations import euler213_deg_to_matrix

FRAMES = 40


def _mfns(*args: str) -> None:
    res = subprocess.run([sys.executable, "-m", "mfns", *args], check=False, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr


@pytest.fixture(scope="module")
def frames(tmp_path_factory) -> tuple[Path, Path, list[str]]:
    """Module scenario frames (survey error rendered, as the self-survey flies), their table,
    and the start pose a replay is given (the first truth row)."""
    out = tmp_path_factory.mktemp("fixlog")
    fr = out / "frames"
    _mfns(
        "sim",
        "nav",
        str(fr),
        "--quiet",
        "--scenario",
        "module",
        "--frames",
        str(FRAMES),
        "--seed",
        "3",
        "--survey-error",
    )
    _mfns("table", "build", str(fr / "calib.json"), str(fr / "beacons.csv"), "-o", str(out / "t.mfnstbl"))
    first = (fr / "truth.csv").read_text().splitlines()[1].split(",")[2:8]
    return fr, out / "t.mfnstbl", ["--init-pose=" + ",".join(first)]


def _fly(bins: Path, frames, out: Path, *extra: str) -> tuple[str, list[dict]]:
    """mfns-nav on the frames with extra options, mfns-ground on its telemetry -> (mfns-nav's
    stderr, nav.csv rows)."""
    fr, table, init = frames
    run = fly_replay(bins, table, fr, out, *init, *extra)
    return run.nav_stderr, run.rows()


def _summary(stderr: str) -> tuple[int, int, int]:
    # only records on disk count as written (issue 45); a record lost to a write error is
    # neither written nor dropped, and counted in the errors here
    m = re.search(
        r"fix log .*: (\d+) fixes written, (\d+) lost to write errors \((\d+) write errors\), (\d+) dropped",
        stderr,
    )
    assert m, stderr
    return int(m[1]), int(m[4]), int(m[3]) + int(m[2])


def _usable(rows: list[dict]) -> dict[int, dict]:
    return {int(r["cycle"]): r for r in rows if r["status"] in fixlog.USABLE}


def test_fixlog_matches_the_runs_telemetry(bins, frames, tmp_path):
    stderr, rows = _fly(bins, frames, tmp_path / "run", "--fixlog", str(tmp_path / "log"))
    recorded, dropped, errors = _summary(stderr)
    assert (dropped, errors) == (0, 0)
    fixes, incomplete = fixlog.read(tmp_path / "log")
    assert incomplete == 0
    usable = _usable(rows)
    assert len(usable) >= FRAMES // 2, stderr  # the run did fly: most cycles give a fix
    # the same cycles: every usable cycle of the telemetry is in the log, and nothing else
    assert [f.cycle for f in fixes] == sorted(usable)
    assert recorded == len(fixes)
    fr = frames[0]
    cams = rig_from_doc(json.loads((fr / "calib.json").read_text()))
    ids, p_w, _ = load_beacons(fr / "beacons.csv")
    where = {int(i): n for n, i in enumerate(ids)}
    for f in fixes:
        r = usable[f.cycle]
        # the same pose (the NAV packet the link carried, decoded by the C ground)
        assert f.status == r["status"]
        assert abs(f.t_s - float(r["t_s"])) < 1e-3
        np.testing.assert_allclose(f.r_wb_w, [float(r[a + "_mm"]) for a in "xyz"], atol=1e-3)
        c = euler213_deg_to_matrix([float(r[a + "_deg"]) for a in ("roll", "pitch", "yaw")])
        assert np.degrees(np.linalg.norm(f.C_w_b - c)) < 1e-3
        assert np.all(np.linalg.eigvalsh(f.cov) > 0)
        # what the fix used: at least 4 inliers, known beacons and cameras, positive covariances
        assert f.used.sum() >= 4
        assert set(f.camera.tolist()) <= {0, 1, 2}
        assert all(int(b) in where for b in f.beacon_id)
        assert np.all(np.linalg.eigvalsh(f.cov_uv) > 0)
        # and where it says: each used centroid is within a few pixels of its beacon's
        # projection at the fix's pose through the calibration (survey error 0.4 mm is
        # ~0.1 px at these ranges; a wrong beacon id or camera would be tens of pixels off)
        r_bw_b = pose_from_position(f.C_w_b, f.r_wb_w)
        for k, b, uv, used in zip(f.camera, f.beacon_id, f.uv, f.used, strict=True):
            pred, vis = cams[int(k)].project(f.C_w_b, r_bw_b, p_w[where[int(b)]][None, :])
            if used:
                assert vis[0]
                assert np.linalg.norm(pred[0] - uv) < 2.0, (f.cycle, int(k), int(b), pred[0], uv)


def test_fixlog_rotates_within_its_bounds_and_continues_after_restart(bins, frames, tmp_path):
    """Three runs into one directory, 1 kB files, 2 kept. Each run starts a new file after the
    last one's number (a restart continues the numbering), so at least three files are written
    and the oldest must go, whatever the writer's batching (it wakes every 10 ms and writes
    what the loop published, so how many files one short run writes depends on the machine)."""
    log = tmp_path / "log"
    kb, keep, ring = 1, 2, 256 * 1024
    last = 0
    for run in ("a", "b", "c"):
        stderr, rows = _fly(
            bins, frames, tmp_path / run, "--fixlog", str(log), f"--fixlog-rotate={kb},{keep}"
        )
        assert _summary(stderr)[1:] == (0, 0)
        files = fixlog.log_files(log)
        nums = [int(p.stem.split("_")[1]) for p in files]
        assert len(files) <= keep
        assert nums == list(range(nums[0], nums[0] + len(nums)))  # consecutive: the oldest went first
        assert nums[-1] > last  # this run wrote a new file after the previous run's
        last = nums[-1]
        # a file is closed once it holds KB kB, after the writer's batch of whole records (at
        # most the ring, NAV_FIXLOG_RING_BYTES, past the limit: nav_fixlog.h)
        assert all(0 < p.stat().st_size <= kb * 1024 + ring for p in files)
        # each file starts and ends at a record boundary: read alone, whole fixes only
        for p in files:
            got, incomplete = fixlog.read(p)
            assert incomplete == 0 and got
        # the newest file holds this run's last usable cycles, in order
        newest, _ = fixlog.read(files[-1])
        usable = sorted(_usable(rows))
        assert [f.cycle for f in newest] == usable[len(usable) - len(newest) :]
    assert last >= 3  # three files at least were written, two kept


def test_fixlog_rotate_refuses_bad_values(bins, frames, tmp_path):
    fr, table, _ = frames
    for bad in ("4", "0,3", "4,0", "x,3", "4,-1"):
        res = subprocess.run(
            [
                str(bins / "mfns-nav"),
                "--table",
                str(table),
                "--replay",
                str(fr),
                "--fixlog",
                str(tmp_path),
                "--fixlog-rotate",
                bad,
            ],
            check=False,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert res.returncode == 2, (bad, res.stderr)
        assert "--fixlog-rotate" in res.stderr
