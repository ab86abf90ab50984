"""Studies on Dask (mfns.core.study, docs/studies.md): a study run on a LocalCluster of 2 worker
processes gives the serial run's results byte for byte (a toy study and the Monte Carlo's pose
points, `mfns mc`), task seeds depend on the study seed and the task index only, and a failed
task is reported with its inputs, retried once, and the other results kept. About 15 s (one
local cluster of 2 worker processes, reached by its address as --scheduler would; the Monte
Carlo is small). A study starting its own local cluster (--workers 2) is run by `mfns mc` in
tests/host/test_mc.py and by the fault campaign's -j 2 in tests/host/test_fault_stale_cameras.py."""

from __future__ import annotations

import filecmp
import json
from pathlib import Path

import numpy as np
import pytest

from mfns.analysis import mc
from mfns.cli import main
from mfns.core import study

HERE = str(Path(__file__).resolve().parent)  # this module, importable on the workers


@pytest.fixture(scope="module")
def cluster():
    """One LocalCluster of 2 worker processes for the module's studies (its address, as
    --scheduler would give it): one start-up instead of one per study."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc:
        yield study.StudyOptions(scheduler=lc.scheduler_address, progress=False)


def seeded_draws(task: tuple[int, int]) -> tuple[int, int, str]:
    """A toy task: its seed's first draws, as the bytes a study would write."""
    index, seed = task
    x = np.random.default_rng(seed).normal(size=4)
    return index, seed, x.tobytes().hex()


def flaky(task: tuple[str, str]) -> str:
    """Fails on its first attempt (a marker file says it ran), succeeds on the second; "never"
    always fails."""
    kind, marker = task
    if kind == "never":
        raise ValueError("this task always fails")
    if kind == "exit":  # a task that calls sys.exit (mfns' scripts do) fails alone
        raise SystemExit("bench: failed")
    if kind == "once" and not Path(marker).exists():
        Path(marker).write_text("tried")
        raise RuntimeError("first attempt fails")
    return f"{kind} done"


def threads_seen(task: int) -> tuple[int, list[int], dict[str, str | None], str]:
    """What a task's numerical libraries run on: the BLAS/OpenMP pools' thread counts in the
    task's process, the thread variables its programs would inherit, and a child Python's view."""
    import os
    import subprocess
    import sys

    from threadpoolctl import threadpool_info

    env = {k: os.environ.get(k) for k in study.THREAD_ENV}
    code = "import numpy, threadpoolctl as t; print(max(p['num_threads'] for p in t.threadpool_info()))"
    child = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.strip()
    return task, sorted({p["num_threads"] for p in threadpool_info()}), env, child


def test_tasks_run_single_threaded_serially_and_on_the_cluster(cluster) -> None:
    """A BLAS reduction over threads sums in another order (the survey bench's refined maps
    differed in their last bits, serial against cluster): every task runs on one thread,
    in its process and in the programs it starts, wherever it runs; the caller's own
    environment is left as it was."""
    import os

    before = {k: os.environ.get(k) for k in study.THREAD_ENV}
    ser = study.run_tasks(threads_seen, [0, 1], study.SERIAL)
    par = study.run_tasks(threads_seen, [0, 1], cluster, paths=[HERE])
    assert ser.results == par.results
    for _, pools, env, child in ser.results:
        assert pools == [1] and child == "1" and set(env.values()) == {"1"}, (pools, env, child)
    assert {k: os.environ.get(k) for k in study.THREAD_ENV} == before


def test_task_seed_is_seedsequence_spawn_of_the_study_seed() -> None:
    kids = np.random.SeedSequence(2026).spawn(5)
    want = [int(k.generate_state(1, np.uint64)[0]) & study.SEED_MASK for k in kids]
    assert study.task_seeds(2026, 5) == want
    assert study.task_seeds(2026, 3) == want[:3]  # a task's seed does not depend on how many
    assert len(set(study.task_seeds(2026, 100))) == 100
    assert all(0 <= s < 2**63 for s in want)
    assert study.task_seed(2027, 0) != want[0]


def test_local_cluster_equals_serial_and_keeps_task_order(cluster, tmp_path: Path, capsys) -> None:
    tasks = list(enumerate(study.task_seeds(7, 12)))
    serial = study.run_tasks(seeded_draws, tasks, study.SERIAL, "toy")
    seen: list[int] = []
    flaky_tasks = [("ok", ""), ("once", str(tmp_path / "once")), ("never", ""), ("ok", "")]
    par = study.run_tasks(
        seeded_draws, tasks, cluster, "toy", on_result=lambda i, _r: seen.append(i), paths=[HERE]
    )
    assert par.results == serial.results  # byte for byte: the same hex of the same draws
    assert sorted(seen) == list(range(12))
    got = study.run_tasks(flaky, flaky_tasks, cluster, "flaky", paths=[HERE])
    assert got.results == ["ok done", "once done", None, "ok done"]
    assert [(f.index, f.attempts) for f in got.failures] == [(2, 2)]
    assert "('never', '')" in got.failures[0].inputs and "always fails" in got.failures[0].error
    assert got.exit_code == 1
    err = capsys.readouterr().err
    assert "flaky: task 1 of 4 failed (inputs: ('once'" in err and "retrying once" in err
    assert "flaky: task 2 of 4 failed (inputs: ('never', ''))" in err and "giving up" in err
    assert "2 (('never', '')): ValueError: this task always fails" in got.failed_summary()


def test_serial_retries_and_keeps_the_others(tmp_path: Path, capsys) -> None:
    tasks = [("once", str(tmp_path / "m")), ("never", ""), ("exit", ""), ("ok", "")]
    got = study.run_tasks(flaky, tasks, study.SERIAL, "flaky")
    assert got.results == ["once done", None, None, "ok done"]
    assert [(f.index, f.attempts) for f in got.failures] == [(1, 2), (2, 2)]
    assert "SystemExit: bench: failed" in got.failures[1].error
    err = capsys.readouterr().err
    assert err.count("retrying once") == 3 and err.count("giving up") == 2


def test_mc_pose_points_on_two_workers_equal_serial(cluster, tmp_path: Path) -> None:
    outs = {}
    for name, options in (("serial", study.SERIAL), ("cluster", cluster)):
        outs[name] = tmp_path / name
        mc.run_mc(outs[name], 100, 3, pose_trials=4, solver="reference", progress=False, options=options)
    files = sorted(p.name for p in outs["serial"].iterdir())
    assert "pose_vs_calib.csv" in files and "summary.json" in files
    match, mismatch, errors = filecmp.cmpfiles(outs["serial"], outs["cluster"], files, shallow=False)
    assert mismatch == [] and errors == [], (mismatch, errors)
    rows = json.loads((outs["cluster"] / "summary.json").read_text())["pose_extension"]["rows"]
    assert [r["group"] for r in rows[:5]] == ["position"] * 5  # task order, not completion order


def test_study_options_have_help_and_check_their_values(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit):
        main(["mc", "--help"])
    text = capsys.readouterr().out
    for opt in ("--scheduler ADDRESS", "--workers N", "--serial"):
        assert opt in text
    out = str(tmp_path / "out")
    assert main(["mc", out, "--workers", "-1", "--pose-trials", "0", "--quiet"]) == 2
    assert main(["mc", out, "--serial", "--scheduler", "tcp://x:1", "--pose-trials", "0"]) == 2
    assert not (tmp_path / "out").exists()  # refused before any work
