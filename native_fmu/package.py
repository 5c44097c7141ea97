"""Package a native FMU: stage its sources and generated tables, compile, write the model description, zip.

The FMU holds modelDescription.xml, a binary per platform built (binaries/linux64/<id>.so,
binaries/win64/<id>.dll, binaries/aarch64-linux/<id>.so: compile.TOOLCHAINS), every C source and
header it was built from under sources/ (listed in the model description, so any other platform can
rebuild it) and resources/build_info.json (the source digest that decides staleness, and the GUID).
"""

from __future__ import annotations

import json
import shutil
import tempfile
import zipfile
from pathlib import Path

from . import compile as cc
from . import describe
from .variables import FmuDefinition

HERE = Path(__file__).parent
LAYER = HERE / "c"
LAYER_FILES = (LAYER / "tl_fmi2.c", LAYER / "tl_fmu.h", LAYER / "tl_noise.h", LAYER / "tl_platform.h")
FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")
BUILD_INFO = "resources/build_info.json"


def fmi_header_dir() -> Path:
    """FMI 2.0 headers as FMPy ships them (the standard's own files)."""
    import fmpy

    folder = Path(fmpy.__file__).parent / "c-code"
    missing = [h for h in FMI_HEADERS if not (folder / h).is_file()]
    if missing:
        raise cc.BuildError(f"FMPy's FMI 2.0 headers are missing: {', '.join(missing)}")
    return folder


def read_build_info(fmu: Path) -> dict | None:
    """The build record of a tiltload FMU (None for any other file)."""
    try:
        with zipfile.ZipFile(fmu) as z:
            return json.loads(z.read(BUILD_INFO))
    except (OSError, KeyError, zipfile.BadZipFile, json.JSONDecodeError):
        return None


def write_fmu(definition: FmuDefinition, sources: cc.NativeSources, target: Path, source_digest: str,
              info: dict | None = None, toolchains: tuple[cc.Toolchain, ...] = ()) -> list[str]:
    """Write target (under a temporary name, then moved) with a binary for each of toolchains (default: every
    platform whose compiler is here); return the compilers' warnings."""
    toolchains = toolchains or cc.choose()[0]
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    guid = describe.guid(definition, source_digest)
    with tempfile.TemporaryDirectory(prefix="tiltload_native_") as tmp:
        stage = Path(tmp)
        src = stage / "sources"
        src.mkdir()
        headers = fmi_header_dir()
        for h in FMI_HEADERS:
            shutil.copy2(headers / h, src / h)
        for f in (*LAYER_FILES, *sources.model, *sources.generated):
            shutil.copy2(f, src / f.name)
        (src / "tl_model.h").write_text(describe.c_header(definition, guid))
        (src / "tl_model_tables.c").write_text(describe.c_tables(definition))
        warnings = []
        for t in toolchains:  # the same sources for every platform
            bin_dir = stage / "binaries" / t.folder
            bin_dir.mkdir(parents=True)
            warnings += cc.compile_shared(sources, src, bin_dir / f"{definition.model_identifier}{t.suffix}", t)
        c_files = sorted(p.name for p in src.glob("*.c"))
        compilers = "; ".join(f"{t.folder}: {cc.compiler_identity(cc.compiler(t))}" for t in toolchains)
        tool = f"tiltload {definition.version} (native FMI 2.0 layer, {compilers})"
        (stage / "modelDescription.xml").write_bytes(describe.model_description(definition, guid, c_files, tool))
        (stage / "resources").mkdir()
        (stage / BUILD_INFO).write_text(json.dumps({"source_hash": source_digest, "guid": guid, **(info or {}),
                                                    "platforms": [t.folder for t in toolchains], "warnings": warnings}, indent=1))
        partial = target.with_name(target.name + ".partial")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(stage.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(stage).as_posix())
        partial.replace(target)
    return warnings
