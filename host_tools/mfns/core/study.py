"""Run a study's independent tasks: serially, on a local Dask cluster, or on an existing one.

A study (the Monte Carlo's pose points, the fault campaign's faults, the survey bench's seeds,
the plan fly check's flights) is a list of task inputs and one task function. `run_tasks` calls
the function on every input and returns the results in task order, whatever the order the
tasks finished in:

- serially (`--serial`, or `--workers 0` / `--workers 1`): in this process, one task after the
  other: the same function on the same inputs, no Dask imported;
- on a local cluster (the default): a `dask.distributed.LocalCluster` of worker *processes*
  (one thread each) over the machine's cores (`--workers N` for N), no more workers than tasks;
  a study of one task runs in-process (a cluster would be all start-up);
- on an existing cluster (`--scheduler tcp://HOST:8786`): `dask scheduler` and `dask worker`s
  started by the user (docs/studies.md); every worker needs the mfns package (and the flight
  programs and the study's files, for studies that fly them) at the same paths.

Determinism: a task's randomness comes from its inputs only. `task_seeds(study_seed, n)` gives
task i the seed of numpy's `SeedSequence(study_seed).spawn(n)[i]` (the same as
`SeedSequence(study_seed, spawn_key=(i,))`), reduced to 63 bits so that it can be passed to a
program's `--seed`: it depends on the study seed and the index only, never on the worker that
runs the task nor on how many there are. Callers put the seed into the task's inputs, so a
failure report shows it.

Failure: a task that raises is reported on stderr with its index and inputs and retried once
(on any worker); if it fails again it is reported as failed, its result is None, and the other
tasks' results are kept: `StudyResult.failures` names the failed tasks, and the study's command
writes what it has and exits 1 (`StudyResult.exit_code`).

Threads: every task runs with its numerical libraries on one thread, wherever it runs
(`single_threaded`: OpenBLAS/MKL/OpenMP limited to 1 in the process, and OMP_NUM_THREADS,
OPENBLAS_NUM_THREADS and MKL_NUM_THREADS set to 1 for the programs it starts, as Dask's
nannies do for their workers). A BLAS reduction split over threads sums in another order:
before this, the 16-seed survey bench run serially (OpenBLAS on 2 threads) and on the local
cluster gave the same tables, but refined maps that differed in their last bits and, through
the tables built from them, nav.csv values from the 10th digit on (7 Dec 2026).

Progress: a tqdm bar over tasks on stderr when stderr is a terminal (quiet otherwise).

Imports on workers: a task function defined in a script (`__main__`) is shipped by value
(cloudpickle); the modules it uses are imported on the worker by name, so the script's own
folders are put on every worker's sys.path (`paths=`, a worker plugin that also reaches workers
that join later) and on the scheduler's (it unpickles the task graph).
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
import uuid
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from .errors import MfnsError

# 2**63 - 1: seeds fit a signed 64-bit integer (the programs' --seed, numpy's default_rng)
SEED_MASK = (1 << 63) - 1
RETRIES = 1  # a failed task is tried once more, then reported as failed
INPUTS_SHOWN = 300  # characters of a task's inputs in a failure report


def task_seed(study_seed: int, index: int) -> int:
    """The seed of task `index` of a study seeded `study_seed` (see the module's header)."""
    import numpy as np

    if study_seed < 0 or index < 0:
        raise MfnsError("study seeds and task indices are non-negative integers")
    ss = np.random.SeedSequence(study_seed, spawn_key=(index,))
    return int(ss.generate_state(1, np.uint64)[0]) & SEED_MASK


def task_seeds(study_seed: int, n: int) -> list[int]:
    """Seeds of tasks 0..n-1 (task_seed of each index)."""
    return [task_seed(study_seed, i) for i in range(n)]


@dataclass
class StudyOptions:
    """Where a study runs. workers None: the machine's cores; 0 or 1, or serial: in-process."""

    scheduler: str | None = None
    workers: int | None = None
    serial: bool = False
    progress: bool | None = None  # None: when stderr is a terminal

    @property
    def in_process(self) -> bool:
        return self.scheduler is None and (self.serial or self.workers in (0, 1))

    def describe(self) -> str:
        if self.scheduler is not None:
            return f"the Dask cluster at {self.scheduler}"
        if self.in_process:
            return "serially, in this process"
        return f"a local Dask cluster of {self.workers or os.cpu_count() or 1} worker processes"


SERIAL = StudyOptions(serial=True, progress=False)


def add_arguments(parser: argparse.ArgumentParser, default_serial: bool = False) -> None:
    """The options every study command takes (--scheduler, --workers, --serial)."""
    g = parser.add_argument_group("where the study runs (docs/studies.md)")
    g.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="run the tasks on this existing Dask cluster (e.g. tcp://10.0.0.5:8786, started with "
        "`dask scheduler` and `dask worker ADDRESS` on each machine; every worker needs the mfns "
        "package, the flight programs and the study's files at the same paths)",
    )
    g.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes of the local Dask cluster (default: the machine's cores; 0 or 1: "
        "serially in this process)",
    )
    g.add_argument(
        "--serial",
        action="store_true",
        default=default_serial,
        help="run the tasks one after the other in this process (no Dask): the same results, byte for byte",
    )


def options_from_args(args: argparse.Namespace, progress: bool | None = None) -> StudyOptions:
    workers = getattr(args, "workers", None)
    if workers is not None and workers < 0:
        raise MfnsError("--workers must be >= 0")
    scheduler = getattr(args, "scheduler", None)
    serial = bool(getattr(args, "serial", False))
    if scheduler and serial:
        raise MfnsError("--serial and --scheduler exclude each other")
    return StudyOptions(scheduler=scheduler, workers=workers, serial=serial, progress=progress)


@dataclass
class TaskFailure:
    index: int
    inputs: str  # repr of the task's inputs, cut to INPUTS_SHOWN characters
    error: str  # the last attempt's exception, one line
    attempts: int


@dataclass
class StudyResult:
    results: list[Any]  # in task order; None where the task failed
    failures: list[TaskFailure] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        return 1 if self.failures else 0

    def failed_summary(self, what: str = "tasks") -> str:
        items = "; ".join(f"{f.index} ({f.inputs}): {f.error}" for f in self.failures)
        return f"{len(self.failures)} of {len(self.results)} {what} failed: {items}"


def _inputs(task: Any) -> str:
    text = repr(task)
    return text if len(text) <= INPUTS_SHOWN else text[: INPUTS_SHOWN - 3] + "..."


def _one_line(e: BaseException) -> str:
    return traceback.format_exception_only(type(e), e)[-1].strip()


def _report(desc: str, index: int, n: int, task: Any, e: BaseException, again: bool) -> None:
    what = "retrying once" if again else "giving up"
    print(
        f"{desc}: task {index} of {n} failed (inputs: {_inputs(task)}): {_one_line(e)}; {what}",
        file=sys.stderr,
        flush=True,
    )


def run_tasks(
    fn: Callable[[Any], Any],
    tasks: Sequence[Any],
    options: StudyOptions = SERIAL,
    desc: str = "study",
    on_result: Callable[[int, Any], None] | None = None,
    paths: Sequence[str] = (),
) -> StudyResult:
    """fn(task) for every task, results in task order (see the module's header).

    on_result(index, result) is called in this process as each task succeeds (in completion
    order): for printing rows as they come. paths: folders the workers import the task's
    modules from (a script's folder)."""
    tasks = list(tasks)
    progress = sys.stderr.isatty() if options.progress is None else options.progress
    from tqdm import tqdm

    bar = tqdm(total=len(tasks), desc=desc, unit="task", disable=not progress or not tasks)
    try:
        # one task and no named cluster: a local cluster would be all start-up
        if options.in_process or len(tasks) < 2 and options.scheduler is None:
            return _serial(fn, tasks, desc, on_result, bar)
        return _dask(fn, tasks, options, desc, on_result, bar, paths)
    finally:
        bar.close()


THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextmanager
def single_threaded():
    """The numerical libraries on one thread in this process and in the programs it starts
    while inside (the environment is restored on leaving)."""
    from threadpoolctl import threadpool_limits

    saved = {k: os.environ.get(k) for k in THREAD_ENV}
    os.environ.update({k: "1" for k in THREAD_ENV})
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def call_single_threaded(fn: Callable[[Any], Any], task: Any) -> Any:
    """fn(task) inside single_threaded(): what every task runs as, serially or on a worker."""
    with single_threaded():
        return fn(task)


def _serial(fn, tasks, desc, on_result, bar) -> StudyResult:
    out = StudyResult([None] * len(tasks))
    for i, task in enumerate(tasks):
        for attempt in range(RETRIES + 1):
            try:
                out.results[i] = call_single_threaded(fn, task)
            except (Exception, SystemExit) as e:  # a task's failure (even its sys.exit) is reported
                _report(desc, i, len(tasks), task, e, attempt < RETRIES)
                if attempt == RETRIES:
                    out.failures.append(TaskFailure(i, _inputs(task), _one_line(e), attempt + 1))
                continue
            if on_result is not None:
                on_result(i, out.results[i])
            break
        bar.update(1)
    return out


def _client(options: StudyOptions, n_tasks: int):
    """(client, cluster or None): the cluster named by options, or a local one of processes."""
    import logging

    import dask
    from dask.distributed import Client, LocalCluster

    if options.scheduler is not None:
        try:
            return Client(options.scheduler, timeout="30s"), None
        except OSError as e:
            raise MfnsError(f"no Dask scheduler at {options.scheduler}: {e}") from e
    n = min(options.workers or os.cpu_count() or 1, n_tasks)  # no idle worker to start
    # Dask's nannies start workers with MALLOC_TRIM_THRESHOLD_=65536, which also turns off
    # glibc's adaptive mmap threshold: every large numpy array is then mmapped and unmapped
    # afresh, in the worker and in every program it starts (inherited). `mfns table build`
    # took 51 s instead of 40 s with it, 7.7 s of it in the kernel instead of 0.5 s (6 Dec
    # 2026); the fault campaign's tables summed twice their serial time. Left unset here.
    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,  # a task is one process's work: numpy and the C core single-threaded
            processes=True,
            # its HTTP server on a free port: the scheduler serves one even without a dashboard,
            # and a second study on the machine would otherwise warn that 8787 is taken
            dashboard_address=":0",
            silence_logs=logging.CRITICAL,
        )
    return Client(cluster), cluster


def _dask(fn, tasks, options, desc, on_result, bar, paths) -> StudyResult:
    from dask.distributed import as_completed

    out = StudyResult([None] * len(tasks))
    client, cluster = _client(options, len(tasks))
    try:
        if paths:
            from .study_worker import SysPath, add_paths

            client.run_on_scheduler(add_paths, [str(p) for p in paths])
            client.register_plugin(SysPath(paths))
        # pure=False: every submission is its own task (a retry is not the failed result again)
        run_id = uuid.uuid4().hex[:8]  # keys unique on a shared scheduler
        futures = {
            client.submit(call_single_threaded, fn, t, pure=False, key=f"{desc}-{run_id}-{i}-0"): (i, 0)
            for i, t in enumerate(tasks)
        }
        ac = as_completed(list(futures))
        for fut in ac:
            i, attempt = futures.pop(fut)
            if fut.status == "error":
                e = fut.exception()
                _report(desc, i, len(tasks), tasks[i], e, attempt < RETRIES)
                if attempt < RETRIES:
                    again = client.submit(
                        call_single_threaded,
                        fn,
                        tasks[i],
                        pure=False,
                        key=f"{desc}-{run_id}-{i}-{attempt + 1}",
                    )
                    futures[again] = (i, attempt + 1)
                    ac.add(again)
                    continue
                out.failures.append(TaskFailure(i, _inputs(tasks[i]), _one_line(e), attempt + 1))
            else:
                out.results[i] = fut.result()
                if on_result is not None:
                    on_result(i, out.results[i])
            fut.release()
            bar.update(1)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    out.failures.sort(key=lambda f: f.index)
    return out
