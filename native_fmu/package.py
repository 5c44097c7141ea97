"""Package a native FMU: stage its sources and generated tables, compile, write the model description, zip.

The FMU holds modelDescription.xml, binaries/<platform>/<id>.so, every C source and header it was
built from under sources/ (listed in the model description, so another platform can rebuild it)
and resources/build_info.json (the source digest that decides staleness, and the GUID).
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
LAYER_FILES = (LAYER / "tl_fmi2.c", LAYER / "tl_core.c", LAYER / "tl_core.h", LAYER / "tl_fmu.h", LAYER / "tl_noise.h")
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
              info: dict | None = None) -> list[str]:
    """Write target (under a temporary name, then moved); return the compiler's warnings on our own sources."""
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
        bin_dir = stage / "binaries" / cc.platform_folder()
        bin_dir.mkdir(parents=True)
        warnings = cc.compile_shared(sources, src, bin_dir / f"{definition.model_identifier}.so")
        c_files = sorted(p.name for p in src.glob("*.c"))
        tool = f"tiltload {definition.version} (native FMI 2.0 layer, {cc.compiler_identity(cc.compiler())})"
        (stage / "modelDescription.xml").write_bytes(describe.model_description(definition, guid, c_files, tool))
        (stage / "resources").mkdir()
        (stage / BUILD_INFO).write_text(json.dumps({"source_hash": source_digest, "guid": guid, **(info or {})}, indent=1))
        partial = target.with_name(target.name + ".partial")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(stage.rglob("*")):
                if f.is_file():
                    z.write(f, f.relative_to(stage).as_posix())
        partial.replace(target)
    return warnings
