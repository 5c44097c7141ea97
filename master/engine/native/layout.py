"""The kernel's structs as the compiler laid them out (tl_layout.c exports a row per struct and per field, generated
from the same field tables that declare them in tl_loop.h) compared with kernel.py's ctypes copies when the library
is loaded: a field on one side only, at another offset, of another size or kind (integer, float, pointer) raises
LayoutError naming the struct and the field, before any plan is built on a wrong layout.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass

_C_INTEGERS = {"int", "unsigned int", "bool", "int8_t", "int32_t", "int64_t", "uint32_t", "uint64_t", "size_t"}


class LayoutError(RuntimeError):
    """The kernel's structs and their ctypes copies differ."""


@dataclass(frozen=True)
class Field:
    type: str  # as declared: "const int64_t *", "uint32_t[TL_ENTROPY_WORDS]", "tl_set_fn[TL_TYPES]"
    offset: int
    size: int


def c_layout(lib) -> dict[str, tuple[int, dict[str, Field]]]:
    """The library's layout table: struct -> (its sizeof, its fields in order)."""
    lib.tl_layout.argtypes = [ctypes.c_int, *[ctypes.POINTER(ctypes.c_char_p)] * 3, *[ctypes.POINTER(ctypes.c_int64)] * 2]
    lib.tl_layout.restype = ctypes.c_int
    structure, field, ctype = ctypes.c_char_p(), ctypes.c_char_p(), ctypes.c_char_p()
    offset, size = ctypes.c_int64(), ctypes.c_int64()
    out: dict[str, tuple[int, dict[str, Field]]] = {}
    i = 0
    while lib.tl_layout(i, *map(ctypes.byref, (structure, field, ctype, offset, size))):
        name = structure.value.decode()
        if field.value is None:
            out[name] = (size.value, {})
        else:
            out[name][1][field.value.decode()] = Field(ctype.value.decode(), offset.value, size.value)
        i += 1
    return out


def _c_kind(ctype: str) -> str:
    base = ctype.partition("[")[0].strip()
    if "*" in base or base.endswith(("_fn", "_callback")):  # tl_loop.h's function pointer types end so
        kind = "pointer"
    elif base in ("double", "float"):
        kind = "float"
    elif base.removeprefix("const ") in _C_INTEGERS:
        kind = "integer"
    else:
        raise LayoutError(f"layout.py does not know the C type {ctype!r}: add it to its kinds")
    return kind + ("[]" if "[" in ctype else "")


def _ctypes_kind(t) -> str:
    if issubclass(t, ctypes.Array):
        return _ctypes_kind(t._type_) + "[]"
    if hasattr(t, "_argtypes_"):  # a CFUNCTYPE
        return "pointer"
    code = getattr(t, "_type_", None)
    if isinstance(code, str):  # a simple type's format character
        return "float" if code in "fdg" else "pointer" if code in "PzZ" else "integer"
    return "pointer" if code is not None else "structure"  # POINTER(x) has x as its _type_


def differences(c: dict[str, tuple[int, dict[str, Field]]], structures: dict[str, type[ctypes.Structure]]) -> list[str]:
    """Every way the C layout and the ctypes structures (by C struct name) differ, one line each."""
    out = [f"{name}: the kernel shares it and kernel.py has no ctypes structure for it" for name in c if name not in structures]
    for name, py in structures.items():
        if name not in c:
            out.append(f"{name}: ctypes {py.__name__} stands for a struct the kernel does not declare")
            continue
        size, fields = c[name]
        py_types = dict(py._fields_)
        for field, f in fields.items():
            if field not in py_types:
                out.append(f"{name}.{field}: in C ({f.type} at offset {f.offset}), not in ctypes {py.__name__}")
                continue
            got = getattr(py, field)
            kinds = _c_kind(f.type), _ctypes_kind(py_types[field])
            if (got.offset, got.size) != (f.offset, f.size) or kinds[0] != kinds[1]:
                out.append(f"{name}.{field}: C {f.type} ({kinds[0]}) at offset {f.offset}, {f.size} bytes; ctypes "
                           f"{py_types[field].__name__} ({kinds[1]}) at offset {got.offset}, {got.size} bytes")
        out.extend(f"{name}.{field}: in ctypes {py.__name__}, not in C" for field in py_types if field not in fields)
        if ctypes.sizeof(py) != size:
            out.append(f"{name}: sizeof {size} in C, {ctypes.sizeof(py)} in ctypes {py.__name__}")
    return out


def check(lib, structures: dict[str, type[ctypes.Structure]]) -> None:
    """Raise LayoutError naming every struct and field where the library and the ctypes structures differ."""
    problems = differences(c_layout(lib), structures)
    if problems:
        raise LayoutError("the kernel's structs and kernel.py's ctypes structures differ (tl_loop.h's field tables and "
                          "kernel.py must change together): " + "; ".join(problems))
