"""The wheel's build step: the C core inside the package (mfns/libmfns_core.so).

pyproject.toml holds the metadata; this file adds only what setuptools cannot declare:

- build_py compiles the C core into the wheel's mfns/ with the Makefile's one recipe
  (`make -C <repo> pkg-core-lib`, mk/pkg.mk: the binding check, then CORE_LIB_CC on the
  sources of CORE_DIRS and HOST_CORE_DIR), and copies the Yamcs configuration
  (ground/yamcs/etc) into mfns/data/yamcs and the XTCE dictionaries (contract/*.xml) into
  mfns/data, so `mfns.ground.ground_yamcs` needs no repository.
  An editable install (`make venv`) builds nothing: the binding then loads the tree's build
  (`make lib`), see mfns/core/binding.py `lib_path`.
- build_py also builds the host (host-sim) flight and ground programs into mfns/bin/
  (`make -C <repo> pkg-programs`, mk/pkg.mk: the Makefile's own mfns-nav and mfns-ground
  targets with BUILD in a temporary folder), run by the console scripts `mfns-nav` and
  `mfns-ground` (mfns/programs.py), as the cmake and ninja wheels carry their binaries: a
  pip install flies sim -> table -> fly -> report without the repository.
- The wheel is tagged py3-none-<platform>: it holds a native library loaded with ctypes,
  not a CPython extension, so any Python >= 3.11 on the same platform can use it.
- Nothing is written into the tree: setuptools' build folder and the egg-info go to a
  temporary folder removed when the build ends.

Why setuptools and a build step rather than scikit-build-core or meson-python: the library
is one gcc call over the sources the Makefile already lists, setuptools is already the
backend and pinned in host_tools/requirements.txt (offline from the pip cache), and CMake or
Meson would be a second description of the same sources to keep in step with the Makefile.
Needs to build: the repository around host_tools (the C sources), GNU make and gcc. A
source distribution cut from host_tools alone cannot build the library (it says so).
"""

from __future__ import annotations

import atexit
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

from setuptools import Distribution, setup
from setuptools.command.build_py import build_py

try:
    from setuptools.command.bdist_wheel import bdist_wheel
except ImportError:  # setuptools < 70.1
    from wheel.bdist_wheel import bdist_wheel

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
LIB_NAME = "libmfns_core.so"
YAMCS_ETC = REPO / "ground" / "yamcs" / "etc"
# the XTCE dictionaries' one source (contract/README.md); the package reads them at run time
DICTIONARIES = [REPO / "contract" / n for n in ("mfns_tm.xml", "mfns_tc.xml", "mfns_ground.xml")]
OPERATOR_PAGE = REPO / "ground" / "operator" / "index.html"


class BuildPyWithCore(build_py):
    """build_py, then the C core and the Yamcs configuration into the built package."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return  # an editable install uses the tree's build (make lib)
        if not (REPO / "Makefile").exists() or not (REPO / "firmware" / "nav").is_dir():
            raise SystemExit(
                f"mfns: the C core's sources are not beside {HERE} (build the wheel from the "
                "repository: pip install ./host_tools, or pip wheel ./host_tools)"
            )
        out = Path(self.build_lib).resolve() / "mfns" / LIB_NAME
        cmd = [
            "make",
            "-s",
            "--no-print-directory",
            "-C",
            str(REPO),
            "pkg-core-lib",
            f"PKG_CORE_LIB={out}",
            f"PYTHON={sys.executable}",
            "BOARD=host-sim",
        ]
        self.announce(" ".join(cmd), level=2)
        try:
            subprocess.run(cmd, check=True)
        except (OSError, subprocess.CalledProcessError) as e:
            raise SystemExit(f"mfns: building {LIB_NAME} failed ({e}); needs GNU make and gcc") from e
        bin_dir = Path(self.build_lib).resolve() / "mfns" / "bin"
        objs = Path(_tmp) / "programs"
        cmd = [
            "make",
            "-s",
            "--no-print-directory",
            "-C",
            str(REPO),
            f"-j{min(os.cpu_count() or 1, 4)}",
            "pkg-programs",
            f"PKG_BIN_DIR={bin_dir}",
            f"PKG_BUILD_DIR={objs}",
            f"PYTHON={sys.executable}",
        ]
        self.announce(" ".join(cmd), level=2)
        try:
            subprocess.run(cmd, check=True)
        except (OSError, subprocess.CalledProcessError) as e:
            raise SystemExit(
                f"mfns: building the flight and ground programs failed ({e}); needs the flight "
                "build's packages (mk/deps.sh)"
            ) from e
        for src in DICTIONARIES:  # mfns.data.dictionary finds them here once installed
            shutil.copy2(src, Path(self.build_lib) / "mfns" / "data" / src.name)
        etc = Path(self.build_lib) / "mfns" / "data" / "yamcs"
        shutil.copytree(YAMCS_ETC, etc, dirs_exist_ok=True)
        # the operator's view (mfns.ground.ground_yamcs_view) serves this page
        shutil.copy2(OPERATOR_PAGE, Path(self.build_lib) / "mfns" / "data" / "operator.html")


class NativeDistribution(Distribution):
    """The package holds a native library: installed to platlib, wheel not pure."""

    def has_ext_modules(self):
        return True


class PlatformWheel(bdist_wheel):
    """A wheel for this platform (it holds a native library) for any Python 3."""

    def get_tag(self):
        plat = sysconfig.get_platform().replace("-", "_").replace(".", "_")
        return "py3", "none", plat


# setuptools writes build/ and mfns.egg-info beside setup.py unless told otherwise: both go
# to a temporary folder (the wheel is written to pip's output folder before it is removed)
_tmp = tempfile.mkdtemp(prefix="mfns-build-")
atexit.register(shutil.rmtree, _tmp, True)

setup(
    distclass=NativeDistribution,
    cmdclass={"build_py": BuildPyWithCore, "bdist_wheel": PlatformWheel},
    options={
        "build": {"build_base": os.path.join(_tmp, "build")},
        "egg_info": {"egg_base": _tmp},
    },
)
