"""The `mfns` command: discovers the subcommands in mfns.commands and runs one.

One grammar for every program of the project (README "Command-line grammar"): every
`mfns` command and subcommand takes `-h/--help`, `--version`, `-q/--quiet` and
`-v/--verbose`, added here once (MfnsParser), so a subcommand cannot forget them.

Exit codes: 0 ok, 1 the job failed, 2 bad usage or bad input. Errors that users can
cause (bad paths, bad files, bad parameters) are raised as `MfnsError` and printed as
one line with exit 2, never a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import pkgutil
import sys
import time

from . import __version__, commands
from .core.errors import MfnsError

EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2


class MfnsParser(argparse.ArgumentParser):
    """An ArgumentParser with the options every mfns command shares.

    Sub-parsers are made with the class of their parent, so nested commands (`mfns sim
    nav`, `mfns table build`) get the same options. A command that defines one of them
    again gets the common one: the meaning is the same in every command.
    """

    COMMON = frozenset({"--version", "-q", "--quiet", "-v", "--verbose"})

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        super().add_argument("--version", action="version", version=f"{self.prog} {__version__}")
        super().add_argument(
            "-q",
            "--quiet",
            action="store_true",
            help="print nothing but warnings and errors (files are written)",
        )
        super().add_argument(
            "-v", "--verbose", action="store_true", help="also print the time the command took"
        )

    def parse_known_args(self, args=None, namespace=None):
        # kept for error(): the words this parser was given (a sub-parser gets the rest of the
        # command line after its name)
        self._words = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def unknown_options(self) -> list[str]:
        """The words given to this parser that look like options and are none of its own (nor
        an abbreviation of one): `--nope`, `--nope=1`. Words after `--` are operands, and a
        negative number is a value."""
        out = []
        for w in getattr(self, "_words", []):
            if w == "--":
                break
            if not w.startswith("-") or w == "-" or self._negative_number_matcher.match(w):
                continue
            name = w.split("=", 1)[0] if w.startswith("--") else w[:2]
            known = self._option_string_actions
            if name in known or (name.startswith("--") and any(o.startswith(name) for o in known)):
                continue
            out.append(name)
        return out

    def error(self, message: str):
        # argparse reports a missing operand before an unknown option (`mfns calib --nope`
        # says "DATASET is required"): the unknown option is the likelier mistake, so it is
        # named first, in the same one line
        unknown = self.unknown_options()
        if unknown and "unrecognized arguments" not in message:
            message = f"unrecognized arguments: {' '.join(unknown)} ({message})"
        super().error(message)

    def add_argument(self, *names, **kwargs):
        if names and set(names) <= self.COMMON:
            return None  # already there, with the project-wide meaning
        if names == ("out",):
            # an output folder is `--out DIR` in every command (mfns report, mfns-ground);
            # the commands that take it as their positional OUT accept both spellings
            kwargs = dict(kwargs, nargs="?", default=None)
            super().add_argument(
                "--out", dest="out_flag", metavar=kwargs.get("metavar", "OUT"), help=kwargs.get("help")
            )
            return super().add_argument("out", **kwargs)
        return super().add_argument(*names, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    parser = MfnsParser(
        prog="mfns",
        description="MFNS host tools (simulation, calibration, analysis, tables, reports)",
        epilog="Exit status: 0 ok, 1 the job failed, 2 bad usage or input.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    func = getattr(args, "func", None)
    if func is None:
        parser.print_help()
        return EXIT_USAGE
    if hasattr(args, "out_flag"):
        if args.out is not None and args.out_flag is not None and args.out != args.out_flag:
            print(f"mfns {args.command}: error: two output folders: OUT and --out differ", file=sys.stderr)
            return EXIT_USAGE
        args.out = args.out if args.out is not None else args.out_flag
        if args.out is None:
            print(
                f"mfns {args.command}: error: the output folder is missing: OUT or --out DIR", file=sys.stderr
            )
            return EXIT_USAGE
    t0 = time.monotonic()
    try:
        # --quiet means the same everywhere: nothing on stdout; warnings and errors go to
        # stderr as usual, and commands with progress bars also turn those off.
        with contextlib.redirect_stdout(io.StringIO()) if args.quiet else contextlib.nullcontext():
            rc = int(func(args) or 0)
    except MfnsError as exc:
        print(f"mfns {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except (OSError, ValueError) as exc:
        print(f"mfns {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    if args.verbose:
        print(f"mfns {args.command}: exit {rc} after {time.monotonic() - t0:.1f} s", file=sys.stderr)
    return rc


if __name__ == "__main__":
    sys.exit(main())
