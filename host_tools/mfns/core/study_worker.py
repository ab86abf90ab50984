"""What a study (mfns.core.study) installs on its Dask workers; imported only when a study
runs on Dask, since it imports distributed."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from distributed.diagnostics.plugin import WorkerPlugin


class SysPath(WorkerPlugin):
    """These folders first on the worker's sys.path: the modules a script's task function uses
    (by name) are found on every worker, also on workers that join later."""

    name = "mfns-study-sys-path"

    def __init__(self, paths: Sequence[str]):
        self.paths = [str(p) for p in paths]

    def setup(self, worker) -> None:
        for p in reversed(self.paths):
            if p not in sys.path:
                sys.path.insert(0, p)


def add_paths(paths: Sequence[str]) -> None:
    """The same on the scheduler (client.run_on_scheduler): it unpickles the task graph, so it
    imports the modules a task's inputs name too."""
    for p in reversed([str(p) for p in paths]):
        if p not in sys.path:
            sys.path.insert(0, p)
