"""The engine's map cannot go stale: every module under master/engine is named in docs/architecture.md, in the bullet of
its own folder, every package folder of the engine has a bullet, and master/command_line's modules are named too. A module
added, moved or split without a line in the map fails here."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENGINE = ROOT / "master" / "engine"


def engine_section(doc: str) -> str:
    start = doc.index("### The engine (`master/engine/`)")
    return doc[start:doc.index("\n### ", start + 1)]


def bullets(section: str) -> dict[str, str]:
    """{folder under the engine ('' for the top level): the text of its bullet}."""
    out = {}
    for item in re.split(r"\n- ", section)[1:]:
        head = re.match(r"\*\*(?:top level|`([\w/]+)/`)\*\*", item)
        assert head, f"a bullet of the engine's map that names no folder: {item[:60]!r}"
        out[head.group(1) or ""] = item
        for sub in re.findall(r"\*\*`([\w/]+)/`\*\*", item[head.end():]):  # a subfolder inside its parent's bullet
            out[sub] = item[item.index(f"**`{sub}/`**"):]
    return out


def unnamed(engine: Path, section: str) -> list[str]:
    """The modules under engine that their folder's bullet does not name (`stem` in backquotes)."""
    by_folder = bullets(section)
    missing = []
    for path in sorted(engine.rglob("*.py")):
        if path.name == "__init__.py" or "__pycache__" in path.parts:
            continue
        folder = path.parent.relative_to(engine).as_posix()
        if f"`{path.stem}`" not in by_folder.get("" if folder == "." else folder, ""):
            missing.append(path.relative_to(engine).as_posix())
    return missing


def test_every_engine_module_is_named_in_its_folders_bullet():
    section = engine_section((ROOT / "docs" / "architecture.md").read_text())
    assert unnamed(ENGINE, section) == [], "not in docs/architecture.md's engine map, in its folder's bullet"


def test_every_engine_package_has_a_bullet_and_every_bullet_a_package():
    section = engine_section((ROOT / "docs" / "architecture.md").read_text())
    folders = {p.parent.relative_to(ENGINE).as_posix() for p in ENGINE.rglob("__init__.py")} - {"."}
    assert set(bullets(section)) - {""} == folders


def test_every_command_line_module_is_named():
    section = engine_section((ROOT / "docs" / "architecture.md").read_text())
    names = sorted(p.stem for p in (ROOT / "master" / "command_line").glob("*.py") if p.name != "__init__.py")
    assert names and [n for n in names if f"`{n}`" not in section] == []


def test_the_check_reports_a_module_its_folders_bullet_does_not_name(tmp_path):
    (tmp_path / "fmi").mkdir()
    for name in ("fmi/__init__.py", "fmi/slave.py", "fmi/brand_new.py", "system.py", "other.py"):
        (tmp_path / name).write_text("")
    section = ("### The engine (`master/engine/`)\n\n- **top level**: `system`, and `slave` named in the wrong bullet\n"
               "- **`fmi/`**: `slave`, and `other` named in the wrong bullet\n")
    assert unnamed(tmp_path, section) == ["fmi/brand_new.py", "other.py"]


APP = ROOT / "master" / "app"


def app_section(doc: str) -> str:
    start = doc.index("### The application (`master/app/`)")
    return doc[start:doc.index("\n## ", start + 1)]


def test_every_application_module_is_named_in_its_folders_bullet():
    """The application's map as the engine's: by concept, every module (and C source) in its folder's bullet."""
    section = app_section((ROOT / "docs" / "architecture.md").read_text())
    missing = unnamed(APP, section)
    by_folder = bullets(section)
    for path in sorted(APP.rglob("*.c")):
        package = path.parent.parent if path.parent.name == "c" else path.parent  # a package's C sources may sit in c/
        folder = package.relative_to(APP).as_posix()
        if f"`{path.name}`" not in by_folder.get("" if folder == "." else folder, ""):
            missing.append(path.relative_to(APP).as_posix())
    assert missing == [], "not in docs/architecture.md's application map, in its folder's bullet"


def test_every_application_package_has_a_bullet_and_the_top_level_keeps_only_entry_points():
    section = app_section((ROOT / "docs" / "architecture.md").read_text())
    folders = {p.parent.relative_to(APP).as_posix() for p in APP.rglob("__init__.py")} - {"."}
    assert set(bullets(section)) - {""} == folders
    top = sorted(p.stem for p in APP.glob("*.py") if p.name != "__init__.py")
    assert top == ["arguments", "cli", "errors", "output_folder", "user_error"], top


# one job per module: no module of the project over MAX_LINES lines (issue 61's must-show; a module that grows past it
# is split by concept, as native/loop.py into paths, links and failures)
MAX_LINES = 400
PACKAGES = ("master", "plant_fmu", "controller_fmu", "sensor_fmu", "scenario_fmu", "native_fmu", "formation", "tiltload")


def test_no_module_is_over_400_lines():
    long = {p.relative_to(ROOT).as_posix(): n for package in PACKAGES for p in sorted((ROOT / package).rglob("*.py"))
            if "__pycache__" not in p.parts and (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}, f"over {MAX_LINES} lines: {long}"
