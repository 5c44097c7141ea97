"""Every repository path named in a comment, a docstring, a C comment or the Markdown docs exists, so that references
left behind by a reorganisation cannot come back. Run as a script, it lists what it finds:
`python tests/test_repo_paths.py`.

A named path is a word ending in a source or docs suffix (.py .c .h .md .toml), with or without folders
(`controller_fmu/fmu/c/tl_zse.c`, `c/tl_zse.c`, `lkf.py`). It exists when it resolves from the naming file's folder,
from one of that folder's parents, or as the tail of a tracked file's path (`c/tl_fmi2.c` in the docs is
`native_fmu/c/tl_fmi2.c`). Parts of URLs and globs never count; nor do the C files a build writes (read from the
builders), other projects' files (EXTERNAL) and a reader's own file in an example (`my_controller.py`)."""

from __future__ import annotations

import ast
import io
import re
import subprocess
import sys
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# A path: folders and a name with one of these suffixes, not inside a longer word, a URL, a glob or a dotted name.
NAMED = re.compile(r"(?<![\w./:@*<>-])((?:[\w.-]+/)*[\w-]+(?:\.[\w-]+)*\.(?:py|c|h|md))(?![\w/-]|\.\w)")

# Files of other projects: the C library's, numpy's and Python's headers, the FMI standard's headers (FMPy ships
# them), the Reference-FMUs' files (docs compare the layers with them).
EXTERNAL = {"math.h", "Python.h", "bitgen.h", "numpy/random/distributions.h", "fmi2Functions.h", "fmi2FunctionTypes.h",
            "fmi2TypesPlatform.h", "fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h", "src/cosimulation.c",
            "include/model.h", "cosimulation.c", "model.h"}
# what writes an FMU's generated C
BUILDERS = ("native_fmu/package.py", "*/build.py", "*/*/build.py", "*/codegen.py", "master/app/wrap/native.py")


def tracked() -> list[Path]:
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return [Path(line) for line in out.splitlines() if line]


def python_prose(text: str) -> str:
    """The comments and docstrings of a Python file."""
    parts = [node.body[0].value.value for node in ast.walk(ast.parse(text))
             if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body
             and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)
             and isinstance(node.body[0].value.value, str)]
    parts += [tok.string for tok in tokenize.generate_tokens(io.StringIO(text).readline) if tok.type == tokenize.COMMENT]
    return "\n".join(parts)


def c_prose(text: str) -> str:
    """The comments of a C file."""
    return "\n".join(m.group(0) for m in re.finditer(r"/\*.*?\*/|//[^\n]*", text, re.S))


def prose(path: Path, text: str) -> str | None:
    if path.suffix == ".py":
        return python_prose(text)
    if path.suffix in (".c", ".h"):
        return c_prose(text)
    if path.suffix == ".md":
        return text
    return None


def generated_names() -> set[str]:
    """The C files a build writes: the names in the builders' string constants that no tracked file has, and the three
    files CasADi writes for each stem (native_fmu/casadi_c.py: <stem>.c, <stem>.h, <stem>_sizes.h)."""
    names = set()
    for pattern in BUILDERS:
        for path in ROOT.glob(pattern):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.Constant) and isinstance(node.value, str):
                    if re.fullmatch(r"[\w-]+\.[ch]", node.value):
                        names.add(node.value)
                    elif re.fullmatch(r"tl_\w+_gen", node.value):
                        names |= {f"{node.value}.c", f"{node.value}.h", f"{node.value}_sizes.h"}
    return names - {p.name for p in tracked()}


def exists(named: str, where: Path, files: set[str], generated: set[str] = frozenset()) -> bool:
    name = named.split("/")[-1]
    if named in EXTERNAL or name in generated or name.startswith("my_"):  # my_*: the reader's own file, in an example
        return True
    folder = (ROOT / where).parent
    for base in (folder, *folder.parents):
        if (base / named).exists():
            return True
        if base == ROOT:
            break
    return any(f == named or f.endswith("/" + named) for f in files)


def stale_references() -> list[tuple[str, int, str]]:
    """(file, line, named path) of every named path that does not exist."""
    paths = tracked()
    files = {p.as_posix() for p in paths}
    generated = generated_names()
    stale = []
    for path in paths:
        if path.suffix not in (".py", ".c", ".h", ".md") or not (ROOT / path).is_file():
            continue
        text = (ROOT / path).read_text(encoding="utf-8")
        searched = prose(path, text)
        for named in sorted(set(NAMED.findall(searched or ""))):
            if not exists(named, path, files, generated):
                line = next((i for i, row in enumerate(text.splitlines(), 1) if named in row), 0)
                stale.append((path.as_posix(), line, named))
    return stale


@pytest.mark.slow
def test_every_named_path_exists():
    stale = stale_references()
    assert not stale, "paths named that do not exist:\n" + "\n".join(f"  {f}:{line}: {named}" for f, line, named in stale)


@pytest.mark.parametrize("text, named", [
    ("see `controller_fmu/zse.py` and lkf.py", ["controller_fmu/zse.py", "lkf.py"]),
    ("[FMI 3.0](fmi3.md), (docs/faults.md)", ["fmi3.md", "docs/faults.md"]),
    ("https://github.com/modelica/Reference-FMUs/blob/main/src/cosimulation.c", []),  # a URL's path is not ours
    ("tiltload.master.app.cli and x.py.bak and module.py: done", ["module.py"]),
    ("`<fmu>/c/*_model.c`, the spec.toml", []),  # a glob; not a suffix it checks
])
def test_what_counts_as_a_named_path(text, named):
    assert NAMED.findall(text) == named


def test_a_missing_path_is_found_and_an_existing_one_is_not():
    files = {p.as_posix() for p in tracked()}
    here = Path("native_fmu/describe_fmi2.py")
    assert exists("c/tl_fmi2.c", here, files) and exists("native_fmu/c/tl_core.c", here, files)
    assert exists("describe_fmi3.py", here, files) and exists("../plant_fmu/trim.py", here, files)
    assert not exists("controller_fmu/zse.py", here, files) and not exists("c/tl_fmi4.c", here, files)
    assert not exists("tests/reference_trajectories.py", here, files)  # it lives in tests/support/


def test_the_generated_c_is_read_from_the_builders():
    generated = generated_names()
    assert {"tl_model.h", "tl_model_tables.c", "plant_layout.h", "controller_data.h"} <= generated
    assert {"tl_pi_gen.c", "tl_pi_gen.h", "tl_pi_gen_sizes.h"} <= generated
    assert "tl_law.c" not in generated  # a builder names it, but it is a tracked source


if __name__ == "__main__":
    found = stale_references()
    for f, line, named in found:
        print(f"{f}:{line}: {named}")
    print(f"{len(found)} named paths that do not exist")
    sys.exit(1 if found else 0)
