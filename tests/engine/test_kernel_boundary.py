"""The C/Python boundary of the tick loop from one table: the codes Python reads out of tl_codes.h are those the C
compiler sees, and a struct whose C and ctypes sides differ (a field on one side only, even one that fits in the
other's padding, another type or array length) fails when the library is loaded, naming the struct and the field."""
import ctypes
import shutil
import subprocess

import pytest
from tiltload.master.engine.native import codes, kernel, layout

HEADER = kernel.HERE / "tl_codes.h"


def _run_c(tmp_path, body: str) -> str:
    """Compile and run a program with tl_loop.h included; its standard output."""
    source = tmp_path / "probe.c"
    source.write_text(f'#include <stdio.h>\n#include <stddef.h>\n#include "tl_loop.h"\nint main(void) {{\n{body}\nreturn 0;\n}}\n')
    exe = tmp_path / "probe"
    subprocess.run(["cc", "-std=c99", f"-I{kernel.HERE}", str(source), "-o", str(exe)], check=True)
    return subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout


def test_every_code_python_reads_is_the_one_the_c_compiler_sees(tmp_path):
    """Each table expanded by the C preprocessor, its entries printed with the values of the compiled enum constants:
    exactly what codes.py parsed, table by table and in order; each IntEnum is its table without the prefix."""
    tables = codes.read_tables(HEADER.read_text())
    assert {"TL_ERROR_KINDS", "TL_FAULT_ACTIONS", "TL_PART_KINDS", "TL_VALUE_TYPES", "TL_SIDES", "TL_PROFILES",
            "TL_DIMENSIONS"} <= set(tables)
    body = '#define P(name, value) printf("%s %s %d\\n", table, #name, (int)name);\nconst char *table;\n'
    body += "\n".join(f'table = "{t}"; {t}(P)' for t in tables)
    seen: dict[str, list[tuple[str, int]]] = {}
    for line in _run_c(tmp_path, body).splitlines():
        table, name, value = line.split()
        seen.setdefault(table, []).append((name, int(value)))
    assert seen == tables
    for enum, table, prefix in ((codes.ErrorKind, "TL_ERROR_KINDS", "TL_ERROR_"), (codes.Profile, "TL_PROFILES", "TL_PROFILE_"),
                                (codes.FaultAction, "TL_FAULT_ACTIONS", "TL_"), (codes.PartKind, "TL_PART_KINDS", "TL_"),
                                (codes.ValueType, "TL_VALUE_TYPES", "TL_"), (codes.Side, "TL_SIDES", "TL_"),
                                (codes.Dimension, "TL_DIMENSIONS", "TL_")):
        assert [(prefix + m.name, m.value) for m in enum] == tables[table]


def test_the_engine_names_map_onto_the_kernel_codes():
    """The engine's value types and fault names, as the kernel numbers them (fmi2 types are Real, Integer, Boolean;
    stale reads the history as delay does)."""
    assert [codes.value_type(t) for t in ("Real", "Integer", "Boolean")] == [0, 1, 2]
    assert [codes.type_name(c) for c in range(3)] == ["Real", "Integer", "Boolean"]
    assert kernel.FAULT_ACTIONS["stale"] == kernel.FAULT_ACTIONS["delay"] == codes.FaultAction.DELAY
    assert len(kernel.FAULT_ACTIONS) == 11 and kernel.TYPES == 3 and kernel.ENTROPY_WORDS == 16


@pytest.mark.parametrize("text, message", [
    ("#define TL_T(X) \\\n    X(TL_A, 1) X(TL_B, 2) \\\n    X(TL_C, 3)\n", "line 2: not an X(TL_NAME, value) entry of TL_T"),
    ("#define TL_T(X) \\\n    X(TL_A, 0x1)\n", "line 2: not an X"),
    ("#define TL_T(X) \\\n    X(TL_A, 1) \\\n", "runs past the end"),
])
def test_a_table_the_reader_cannot_read_for_sure_fails_at_once(text, message):
    with pytest.raises(codes.CodesError, match=message.replace("(", r"\(").replace(")", r"\)")):
        codes.read_tables(text)


def test_two_entries_of_one_value_or_a_name_without_the_prefix_fail():
    tables = codes.read_tables("#define TL_T(X) \\\n    X(TL_A, 1) /* a */ \\\n    /* between */ \\\n    X(TL_B, 1)\n")
    assert tables == {"TL_T": [("TL_A", 1), ("TL_B", 1)]}
    with pytest.raises(codes.CodesError, match="two entries one value"):
        codes.enum_of(tables, "TL_T", "T")
    with pytest.raises(codes.CodesError, match="TL_A does not start with TL_X_"):
        codes.enum_of(tables, "TL_T", "T", "TL_X_")


def test_the_library_reports_the_layout_the_compiler_gives(tmp_path):
    """Offsets and sizes written out by hand with offsetof and sizeof (not through the field tables) agree with the
    library's rows; every struct's fields lie in order inside it."""
    probes = {("tl_plan", None): "sizeof(tl_plan)", ("tl_plan", "error_kind"): "offsetof(tl_plan, error_kind)",
              ("tl_plan", "overrun"): "offsetof(tl_plan, overrun)", ("tl_fault", "entropy"): "offsetof(tl_fault, entropy)",
              ("tl_instance", "clocks"): "offsetof(tl_instance, clocks)", ("tl_clocks", "lock_depth"): "offsetof(tl_clocks, lock_depth)",
              ("tl_part", "has_applied"): "offsetof(tl_part, has_applied)", ("tl_group", None): "sizeof(tl_group)",
              ("tl_read", "buffer"): "offsetof(tl_read, buffer)"}
    out = _run_c(tmp_path, "\n".join(f'printf("%lld\\n", (long long){expr});' for expr in probes.values()))
    c = layout.c_layout(kernel.library())
    for (struct, field), value in zip(probes, out.split()):
        assert (c[struct][0] if field is None else c[struct][1][field].offset) == int(value), (struct, field)
    assert c["tl_fault"][1]["entropy"].size == 16 * 4 and c["tl_instance"][1]["set"].size == 3 * ctypes.sizeof(ctypes.c_void_p)
    assert set(c) == set(kernel.STRUCTURES)
    for size, fields in c.values():
        spans = sorted((f.offset, f.offset + f.size) for f in fields.values())
        assert spans[0][0] == 0 and spans[-1][1] <= size
        assert all(end <= start for (_, end), (start, _) in zip(spans, spans[1:]))


def _one_changed(name: str, fields: list) -> dict:
    struct = next(k for k, v in kernel.STRUCTURES.items() if v.__name__ == name)
    return {**kernel.STRUCTURES, struct: type(name, (ctypes.Structure,), {"_fields_": fields})}


def test_a_ctypes_field_on_one_side_only_or_of_another_kind_fails_naming_it():
    lib = kernel.library()
    layout.check(lib, kernel.STRUCTURES)  # as loaded: no difference
    with pytest.raises(layout.LayoutError, match=r"tl_group\.extra: in ctypes Group, not in C"):
        layout.check(lib, _one_changed("Group", [*kernel.Group._fields_, ("extra", ctypes.c_int)]))
    with pytest.raises(layout.LayoutError, match=r"tl_part\.has_applied: in C \(int at offset \d+\), not in ctypes Part"):
        layout.check(lib, _one_changed("Part", kernel.Part._fields_[:-1]))
    swapped = [(n, ctypes.c_double if n == "history_capacity" else t) for n, t in kernel.Fault._fields_]  # same size
    with pytest.raises(layout.LayoutError, match=r"tl_fault\.history_capacity: C int64_t \(integer\).*ctypes c_double \(float\)"):
        layout.check(lib, _one_changed("Fault", swapped))
    with pytest.raises(layout.LayoutError, match="tl_plan: the kernel shares it and kernel.py has no ctypes structure"):
        layout.check(lib, {k: v for k, v in kernel.STRUCTURES.items() if k != "tl_plan"})


@pytest.mark.parametrize("file, old, new, named", [
    # an int after tl_part's n lands in the padding before the pointer vrs: no offset moves, the size stays
    ("tl_loop.h", "    F(int, kind) \\\n    F(int, n) \\\n", "    F(int, kind) \\\n    F(int, n) \\\n    F(int, spare) \\\n",
     r"tl_part\.spare: in C \(int at offset 12\)"),
    ("tl_codes.h", "X(TL_ENTROPY_WORDS, 16)", "X(TL_ENTROPY_WORDS, 8)", r"tl_fault\.entropy: C uint32_t\[TL_ENTROPY_WORDS\]"),
])
def test_a_kernel_built_from_changed_c_fails_at_load_naming_the_field(tmp_path, monkeypatch, file, old, new, named):
    """A modified copy of the kernel's headers, its layout table compiled from them: the check refuses it."""
    monkeypatch.setenv("TILTLOAD_CACHE", str(tmp_path / "cache"))
    copy = tmp_path / "native"
    copy.mkdir()
    for f in ("tl_layout.c", "tl_loop.h", "tl_codes.h", "tl_draw.h"):
        shutil.copy(kernel.HERE / f, copy / f)
    text = (copy / file).read_text()
    assert text.count(old) == 1
    (copy / file).write_text(text.replace(old, new))
    lib = kernel.compiled("tl_layout", (copy / "tl_layout.c", copy / "tl_loop.h", copy / "tl_codes.h"))
    if "spare" in new:  # sizeof(tl_part) alone would not tell
        assert layout.c_layout(lib)["tl_part"][0] == ctypes.sizeof(kernel.Part)
    with pytest.raises(layout.LayoutError, match=named):
        layout.check(lib, kernel.STRUCTURES)
