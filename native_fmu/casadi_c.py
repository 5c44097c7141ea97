"""CasADi functions as C sources for a native FMU: the generated code plus a header of work sizes.

The sizes header lets the model's hooks call a generated function with stack buffers:
`<NAME>_SZ_ARG`, `_SZ_RES`, `_SZ_IW`, `_SZ_W` for every function.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca

# Put before CasADi's code (it includes <math.h> after its prefix macros, which does nothing the second time):
# the arithmetic pinned as in tl_platform.h (no contraction: the same results with any compiler's default
# flags), every symbol of the file hidden (the FMU exports the fmi2 functions only; Windows exports nothing
# without CASADI_SYMBOL_EXPORT, which with_export=False leaves out) and the arguments CasADi never reads
# left without a warning. Self-contained: the file compiles without our headers.
PRELUDE = """/* tiltload (native_fmu/casadi_c.py): arithmetic pinned, symbols internal, CasADi's unused arguments quiet. */
#include <math.h>
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#elif defined(_MSC_VER)
#pragma fp_contract(off)
#else
#pragma STDC FP_CONTRACT OFF
#endif
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-parameter"
#if !defined(_WIN32) && !defined(__CYGWIN__)
#pragma GCC visibility push(hidden)
#endif
#endif

"""


def generate(functions: list[ca.Function], directory: Path, stem: str, defines: dict[str, int] | None = None) -> list[Path]:
    """Write <stem>.c, <stem>.h and <stem>_sizes.h (with any extra integer defines) into directory; return the three paths."""
    directory.mkdir(parents=True, exist_ok=True)
    cg = ca.CodeGenerator(f"{stem}.c", {"with_header": True, "with_export": False})
    for f in functions:
        cg.add(f)
    cg.generate(str(directory) + "/")
    source = directory / f"{stem}.c"
    source.write_text(PRELUDE + source.read_text())
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
