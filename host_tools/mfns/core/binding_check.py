"""Generate binding_check_gen.c: the Python binding (binding.py) held to the C headers.

For every struct of binding.STRUCTS: `_Static_assert` on its size, on each field's offset
and on each field's type (`_Generic` on the field; arrays by element type and by the count
of every dimension; nested structs by their C type name; enums and pointers by the C type
named in the class's `_c_types_`; anonymous members through their parent), and one on each
constant of binding.CONSTANTS; and one call of each function of binding.PROTOTYPES with
arguments and result of the types the binding declares. mk/binding.mk compiles the file
with the core's headers as part of `make lib`, so a binding that disagrees with a header
fails the build.

Standard library only (it runs with plain python3, before the venv exists):
    python3 host_tools/mfns/core/binding_check.py           write the file
    python3 host_tools/mfns/core/binding_check.py --check   fail when the committed file is stale
"""

from __future__ import annotations

import argparse
import ctypes as ct
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE.parent / "generated" / "binding_check_gen.c"

# ctypes scalar -> the C type _Generic must see (ctypes aliases: c_int is c_int32, c_uint is
# c_uint32, c_ushort is c_uint16, ... on the LP64 hosts the library is built for).
SCALARS = {
    ct.c_float: "float",
    ct.c_double: "double",
    ct.c_bool: "_Bool",
    ct.c_char: "char",
    ct.c_int8: "int8_t",
    ct.c_uint8: "uint8_t",
    ct.c_int16: "int16_t",
    ct.c_uint16: "uint16_t",
    ct.c_int32: "int32_t",
    ct.c_uint32: "uint32_t",
    ct.c_int64: "int64_t",
    ct.c_uint64: "uint64_t",
}


def _is_array(t) -> bool:
    return isinstance(t, type) and issubclass(t, ct.Array)


def _is_record(t) -> bool:
    return isinstance(t, type) and issubclass(t, (ct.Structure, ct.Union))


def _is_pointer(t) -> bool:
    return isinstance(t, type) and issubclass(t, (ct._Pointer, ct.c_void_p, ct.c_char_p))


def _type_test(expr: str, ctype: str) -> str:
    return f"_Generic({expr}, {ctype}: 1, default: 0)"


def _field_checks(ctype: str, where: str, path: str, t, override: str | None) -> list[tuple[str, str]]:
    """(condition, message) pairs for the field at C member path `path` of struct `ctype`."""
    out: list[tuple[str, str]] = []
    f = f"MFNS_FIELD({ctype}, {path})"
    if override is not None:
        out.append((_type_test(f, override), f"{where}: C type is not {override}"))
        if not _is_pointer(t):  # (the pointer's type test fixes its size)
            out.append((f"sizeof({f}) == {ct.sizeof(t)}u", f"{where}: {ct.sizeof(t)} bytes here"))
        return out
    if _is_pointer(t):
        raise SystemExit(f"binding_check: {where} is a pointer: name its C type in _c_types_")
    elem, expr, dims = t, f, []
    while _is_array(elem):
        dims.append(elem._length_)
        out.append(
            (f"sizeof({expr}) == {elem._length_}u * sizeof({expr}[0])", f"{where}: {elem._length_} elements")
        )
        expr, elem = f"{expr}[0]", elem._type_
    shape = "".join(f"[{n}]" for n in dims)
    if _is_record(elem):
        if elem._c_ is None:
            raise SystemExit(f"binding_check: {where}: an anonymous member cannot be an array element")
        name = elem._c_[1]
    elif elem in SCALARS:
        name = SCALARS[elem]
    else:
        raise SystemExit(f"binding_check: {where}: no C type for {elem.__name__}")
    out.append((_type_test(expr, name), f"{where}: C type is not {name}{shape}"))
    return out


def _record_checks(ctype: str, cls, prefix: str, base: int, label: str) -> list[tuple[str, str]]:
    out: list[tuple[str, str]] = []
    overrides = getattr(cls, "_c_types_", {})
    for name, t in cls._fields_:
        off = base + getattr(cls, name).offset
        path, where = f"{prefix}{name}", f"{label}.{name}"
        out.append((f"offsetof({ctype}, {path}) == {off}u", f"{where}: offset {off} here"))
        if _is_record(t) and t._c_ is None:  # anonymous member: its fields through the parent
            out.append(
                (
                    f"sizeof(MFNS_FIELD({ctype}, {path})) == {ct.sizeof(t)}u",
                    f"{where}: {ct.sizeof(t)} bytes here",
                )
            )
            out += _record_checks(ctype, t, f"{path}.", off, where)
        else:
            out += _field_checks(ctype, where, path, t, overrides.get(name))
    return out


def _c_scalar(t) -> str:
    """The C type of a ctypes scalar (SCALARS; size_t is its fixed-width alias)."""
    if t not in SCALARS:
        raise ValueError(f"binding_check: no C type for {t!r}")
    return SCALARS[t]


def _array_decl(t, name: str) -> str:
    """`elem name[d0][d1]..` for a ctypes array type."""
    dims = []
    while _is_array(t):
        dims.append(t._length_)
        t = t._type_
    return f"{_c_record_or_scalar(t)} {name}" + "".join(f"[{d}]" for d in dims)


def _c_record_or_scalar(t) -> str:
    return t._c_[1] if _is_record(t) else _c_scalar(t)


def _argument(t, name: str) -> tuple[str | None, str]:
    """(declaration of a local of the argument's type or None, the expression passed) for
    one argument of a PROTOTYPES entry: what C sees when ctypes passes that type."""
    if t is ct.c_void_p or t is ct.c_char_p:
        return None, "NULL"  # any pointer: only the argument's place is checked
    if isinstance(t, type) and issubclass(t, ct._Pointer):
        to = t._type_
        if _is_array(to):
            return _array_decl(to, name) + " = {0};", name  # decays as the C array parameter
        return f"{_c_record_or_scalar(to)} {name} = {{0}};", f"&{name}"
    if _is_record(t):
        return f"{t._c_[1]} {name} = {{0}};", name
    return f"{_c_scalar(t)} {name} = 0;", name


def _prototype_checks(binding) -> list[str]:
    """One call of each function of binding.PROTOTYPES with arguments of the declared types,
    its result stored in the declared type: -Werror turns a wrong count, a value where a
    pointer goes, a narrowing or a pointer to another type into a build failure."""
    lines = [
        "",
        "/* PROTOTYPES: each function called as ctypes calls it (compiled, never run) */",
        "void mfns_binding_prototypes(void);",
        "void mfns_binding_prototypes(void)",
        "{",
    ]
    for fn, (res, args) in binding.PROTOTYPES.items():
        decls, exprs = [], []
        for i, t in enumerate(args):
            d, e = _argument(t, f"a{i}")
            if d is not None:
                decls.append(d)
            exprs.append(e)
        call = f"{fn}({', '.join(exprs)})"
        if res is None:
            body = f"{call};"
        elif res is ct.c_char_p:
            body = f"const char *r = {call};\n        (void)r;"
        else:
            body = f"{_c_scalar(res)} r = {call};\n        (void)r;"
        lines += ["    {", *[f"        {d}" for d in decls], f"        {body}", "    }"]
    return lines + ["}"]


def _c_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def generate(binding, source: str = "host_tools/mfns/core/binding.py") -> str:
    """The C text checking the declarations of module `binding` (STRUCTS, CONSTANTS,
    PROTOTYPES)."""
    headers = sorted({cls._c_[0] for cls in binding.STRUCTS} | set(binding.PROTOTYPE_HEADERS))
    lines = [
        f"/* GENERATED by host_tools/mfns/core/binding_check.py from {source}; do not edit */",
        "/* The Python binding held to the C headers: each struct's size, each field's offset and",
        " * type, each constant (compiled by `make lib`, mk/binding.mk). */",
        "#include <stdbool.h>",
        "#include <stddef.h>",
        "#include <stdint.h>",
        "",
        *[f'#include "{h}"' for h in headers],
        "",
        "/* a member of T, for sizeof and _Generic only (never evaluated) */",
        "#define MFNS_FIELD(T, member) (((T *)0)->member)",
        "",
    ]
    for name, (value, expr) in binding.CONSTANTS.items():
        msg = _c_string(f"binding.py {name} = {value}: C {expr} differs")
        # (a macro equal to its literal is the point here: not a redundant expression)
        lines.append(f"_Static_assert({expr} == {value}, {msg}); /* NOLINT(misc-redundant-expression) */")
    for cls in binding.STRUCTS:
        header, ctype = cls._c_
        lines += ["", f"/* {cls.__name__} = {ctype} ({header}) */"]
        size = ct.sizeof(cls)
        checks = [(f"sizeof({ctype}) == {size}u", f"{cls.__name__}: {size} bytes here")]
        checks += _record_checks(ctype, cls, "", 0, cls.__name__)
        lines += [f"_Static_assert({cond}, {_c_string('binding.py ' + msg)});" for cond, msg in checks]
    lines += _prototype_checks(binding)
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="fail when the committed file is stale")
    ap.add_argument("-o", "--output", type=Path, default=OUT)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(HERE.parents[1]))
    from mfns.core import binding

    text = generate(binding)
    if args.check:
        if not args.output.exists() or args.output.read_text() != text:
            print(
                f"{args.output}: stale (binding.py changed): "
                "run python3 host_tools/mfns/core/binding_check.py",
                file=sys.stderr,
            )
            return 1
        return 0
    args.output.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
