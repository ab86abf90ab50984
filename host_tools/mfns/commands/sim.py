"""`mfns sim`: simulate the calibration and navigation experiments (mfns.simulate.*)."""

from __future__ import annotations

import importlib
import pkgutil

from .. import simulate


def register(subparsers) -> None:
    parser = subparsers.add_parser("sim", help="simulate the calibration or navigation experiment")
    sub = parser.add_subparsers(dest="sim_command", metavar="EXPERIMENT")
    for info in sorted(pkgutil.iter_modules(simulate.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{simulate.__name__}.{info.name}")
        reg = getattr(module, "register", None)
        if reg is not None:
            reg(sub)
    parser.set_defaults(func=lambda args: parser.print_help() or 2)
