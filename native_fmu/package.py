"""Package a native FMU: stage its sources and generated tables, compile, write the model description, zip.

The FMU holds modelDescription.xml, a binary per platform built (compile.TOOLCHAINS; FMI 2.0:
binaries/linux64/<id>.so, binaries/win64/<id>.dll, binaries/aarch64-linux/<id>.so; FMI 3.0 the same binaries
under the platform tuples x86_64-linux, x86_64-windows, aarch64-linux), every C source and header it was built
from under sources/ (so any other platform can rebuild it: listed in the FMI 2.0 model description, in
sources/buildDescription.xml for FMI 3.0) and resources/build_info.json (the source digest that decides
staleness, and the GUID or instantiation token). Both versions compile the same hooks and tables; only the
layer differs (c/tl_fmi2.c or c/tl_fmi3.c, sharing c/tl_core.c).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import threading
import zipfile
from pathlib import Path

from . import compile as cc
from . import describe_fmi2, describe_fmi3
from .variables import FmuDefinition

HERE = Path(__file__).parent
LAYER = HERE / "c"
SHARED_FILES = (LAYER / "tl_core.c", LAYER / "tl_core.h", LAYER / "tl_fmu.h", LAYER / "tl_noise.h", LAYER / "tl_platform.h")
LAYER_FILES = (LAYER / "tl_fmi2.c", LAYER / "tl_fmi3.c", *SHARED_FILES)  # every file of the toolkit's C
FMI_HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
               3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
BUILD_INFO = "resources/build_info.json"
FMI_VERSIONS = (2, 3)


def fmi_header_dir(fmi_version: int = 2) -> Path:
    """The FMI headers as FMPy ships them (the standard's own files)."""
    import fmpy

    folder = Path(fmpy.__file__).parent / "c-code"
    missing = [h for h in FMI_HEADERS[fmi_version] if not (folder / h).is_file()]
    if missing:
        raise cc.BuildError(f"FMPy's FMI {fmi_version}.0 headers are missing: {', '.join(missing)}")
    return folder


def read_build_info(fmu: Path) -> dict | None:
    """The build record of a tiltload FMU (None for any other file)."""
    try:
        with zipfile.ZipFile(fmu) as z:
            return json.loads(z.read(BUILD_INFO))
    except (OSError, KeyError, zipfile.BadZipFile, json.JSONDecodeError):
        return None


def _stage_sources(definition: FmuDefinition, sources: cc.NativeSources, src: Path, guid: str, fmi_version: int) -> None:
    if fmi_version == 2:  # FMI 2.0 sources carry the standard's headers; FMI 3.0 importers supply their own
        headers = fmi_header_dir(2)
        for h in FMI_HEADERS[2]:
            shutil.copy2(headers / h, src / h)
    layer = LAYER / ("tl_fmi2.c" if fmi_version == 2 else "tl_fmi3.c")
    for f in (layer, *SHARED_FILES, *sources.model, *sources.generated):
        shutil.copy2(f, src / f.name)
    if fmi_version == 2:
        (src / "tl_model.h").write_text(describe_fmi2.c_header(definition, guid))
        (src / "tl_model_tables.c").write_text(describe_fmi2.c_tables(definition))
    else:
        (src / "tl_model.h").write_text(describe_fmi3.c_header(definition, guid))
        (src / "tl_model_tables.c").write_text(describe_fmi3.c_tables(definition))


def write_fmu(definition: FmuDefinition, sources: cc.NativeSources, target: Path, source_digest: str,
              info: dict | None = None, toolchains: tuple[cc.Toolchain, ...] = (), fmi_version: int = 2) -> list[str]:
    """Write target (under a temporary name, then moved) as an FMI 2.0 or 3.0 co-simulation FMU with a binary for
    each of toolchains (default: every platform whose compiler is here); return the compilers' warnings."""
    if fmi_version not in FMI_VERSIONS:
        raise cc.BuildError(f"FMI version must be one of {', '.join(map(str, FMI_VERSIONS))}, got {fmi_version!r}")
    if definition.clocks and fmi_version != 3:
        raise cc.BuildError(f"{definition.model_identifier} declares clocks: it can only be built as FMI 3.0")
    toolchains = toolchains or cc.choose()[0]
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    guid = describe_fmi2.guid(definition, source_digest)
    api = f"fmi{fmi_version}"
    include = () if fmi_version == 2 else (fmi_header_dir(3),)
    with tempfile.TemporaryDirectory(prefix="tiltload_native_") as tmp:
        stage = Path(tmp)
        src = stage / "sources"
        src.mkdir()
        _stage_sources(definition, sources, src, guid, fmi_version)
        warnings = []
        for t in toolchains:  # the same sources and toolchains for every platform; the FMI version names the folder
            bin_dir = stage / "binaries" / t.binary_folder(fmi_version)
            bin_dir.mkdir(parents=True)
            warnings += cc.compile_shared(sources, src, bin_dir / f"{definition.model_identifier}{t.suffix}", t,
                                          api=api, include=include)
        c_files = sorted(p.name for p in src.glob("*.c"))
        compilers = "; ".join(f"{t.binary_folder(fmi_version)}: {cc.compiler_identity(cc.compiler(t))}" for t in toolchains)
        tool = f"tiltload {definition.version} (native FMI {fmi_version}.0 layer, {compilers})"
        if fmi_version == 2:
            md = describe_fmi2.model_description(definition, guid, c_files, tool)
        else:
            md = describe_fmi3.model_description(definition, guid, tool)
            (src / "buildDescription.xml").write_bytes(describe_fmi3.build_description(definition, c_files))
        (stage / "modelDescription.xml").write_bytes(md)
        (stage / "resources").mkdir()
        (stage / BUILD_INFO).write_text(json.dumps({"source_hash": source_digest, "guid": guid, "fmi_version": fmi_version,
                                                    **(info or {}), "platforms": [t.binary_folder(fmi_version) for t in toolchains],
                                                    "warnings": warnings}, indent=1))
        # one name per process and thread: two builds of the same FMU at once never write the same file
        partial = target.with_name(f"{target.name}.{os.getpid()}.{threading.get_ident()}.partial")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(stage.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(stage).as_posix())
        partial.replace(target)
    return warnings
