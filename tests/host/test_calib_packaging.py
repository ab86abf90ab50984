"""Issue 14 packaging: pyproject's compatible ranges and the pinned lock agree.

The clean-venv install (`pip install ./host_tools`, then mfns --help / sim calib / calib) is
the `pkg-check` suite of make test (mk/pkg-check.sh); this checks the two files cheaply.
"""

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.version import Version

HOST = Path(__file__).resolve().parents[2] / "host_tools"


def _lock() -> dict[str, Version]:
    pins = {}
    for line in (HOST / "requirements.txt").read_text().splitlines():
        m = re.fullmatch(r"([A-Za-z0-9_.-]+)==([^\s#]+)", line.strip())
        if m:
            pins[m.group(1).lower().replace("_", "-")] = Version(m.group(2))
    return pins


def test_every_declared_dependency_is_pinned_within_its_range():
    meta = tomllib.loads((HOST / "pyproject.toml").read_text())["project"]
    declared = list(meta["dependencies"]) + [
        r for extra in meta["optional-dependencies"].values() for r in extra
    ]
    pins = _lock()
    assert {"numpy", "scipy", "opencv-python-headless", "matplotlib", "tqdm"} <= {
        Requirement(r).name.lower() for r in meta["dependencies"]
    }
    for text in declared:
        req = Requirement(text)
        name = req.name.lower()
        assert name in pins, f"{name} declared in pyproject.toml but not pinned in requirements.txt"
        assert req.specifier.contains(pins[name]), (name, str(req.specifier), str(pins[name]))
        assert req.specifier.contains("99999") is False, f"{name}: needs an upper bound"


def test_runtime_needs_no_test_or_benchmark_package():
    meta = tomllib.loads((HOST / "pyproject.toml").read_text())["project"]
    runtime = {Requirement(r).name.lower() for r in meta["dependencies"]}
    assert not runtime & {"pytest", "pyyaml", "ruff", "poselib", "pycolmap"}
