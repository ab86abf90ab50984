"""Subcommands of `mfns`: each module here defines `register(subparsers)`.

`register` adds one sub-parser (with its own --help) and sets `func` to a
callable taking the parsed arguments and returning an exit code. Modules are
found automatically, so adding a command needs no edit elsewhere.
"""
