"""CasADi functions as C sources for a native FMU: the generated code plus a header of work sizes.

The sizes header lets the model's hooks call a generated function with stack buffers:
`<NAME>_SZ_ARG`, `_SZ_RES`, `_SZ_IW`, `_SZ_W` for every function.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca


def generate(functions: list[ca.Function], directory: Path, stem: str, defines: dict[str, int] | None = None) -> list[Path]:
    """Write stem.c, stem.h and stem_sizes.h (with any extra integer defines) into directory; return the three paths."""
    directory.mkdir(parents=True, exist_ok=True)
    cg = ca.CodeGenerator(f"{stem}.c", {"with_header": True})
    for f in functions:
        cg.add(f)
    cg.generate(str(directory) + "/")
    guard = f"{stem.upper()}_SIZES_H"
    lines = [f"/* Work sizes of the CasADi functions in {stem}.c (generated). */", f"#ifndef {guard}", f"#define {guard}"]
    for f in functions:
        n = f.name().upper()
        lines += [f"#define {n}_SZ_ARG {f.sz_arg()}", f"#define {n}_SZ_RES {f.sz_res()}",
                  f"#define {n}_SZ_IW {max(f.sz_iw(), 1)}", f"#define {n}_SZ_W {max(f.sz_w(), 1)}"]
    lines += [f"#define {k} {int(v)}" for k, v in (defines or {}).items()]
    lines += ["#endif", ""]
    sizes = directory / f"{stem}_sizes.h"
    sizes.write_text("\n".join(lines))
    return [directory / f"{stem}.c", directory / f"{stem}.h", sizes]
