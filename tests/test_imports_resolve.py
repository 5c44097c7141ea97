"""Every import of a tiltload module, at any depth (the lazy imports inside functions too, which importing the modules
does not run), names a module that exists: a module moved to another folder leaves no import pointing at its old place."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = {"master": "tiltload.master", "native_fmu": "tiltload.native_fmu", "plant_fmu": "tiltload.plant_fmu",
            "controller_fmu": "tiltload.controller_fmu", "sensor_fmu": "tiltload.sensor_fmu",
            "scenario_fmu": "tiltload.scenario_fmu", "formation": "tiltload.formation", "tiltload": "tiltload"}


def modules() -> dict[str, Path]:
    """Every module of the package by its dotted name (the repository's folders are its subpackages)."""
    found = {}
    for folder, dotted in PACKAGES.items():
        for path in (ROOT / folder).rglob("*.py"):
            parts = [dotted, *path.relative_to(ROOT / folder).with_suffix("").parts]
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def imported(name: str, path: Path, node: ast.ImportFrom) -> str:
    """The dotted name a `from X import ...` names, resolved against the importing module's package."""
    if not node.level:
        return node.module or ""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    base = package.split(".")[:len(package.split(".")) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def test_every_tiltload_import_names_an_existing_module():
    known = modules()
    missing = []
    for name, path in known.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                target = imported(name, path, node)
                if target.startswith("tiltload") and target not in known:
                    missing.append(f"{path.relative_to(ROOT)}:{node.lineno}: {target}")
                elif target in known:  # `from .package import module`: the module must exist, or be a name in it
                    missing += [f"{path.relative_to(ROOT)}:{node.lineno}: {target}.{a.name}" for a in node.names
                                if known[target].name == "__init__.py" and f"{target}.{a.name}" not in known
                                and a.name not in known[target].read_text()]
            elif isinstance(node, ast.Import):
                missing += [f"{path.relative_to(ROOT)}:{node.lineno}: {a.name}" for a in node.names
                            if a.name.startswith("tiltload.") and a.name not in known]
    assert missing == []


def test_every_import_of_the_tests_and_benchmarks_names_an_existing_module():
    """The tests and benchmarks import the installed tiltload by its absolute names: each names a module there (a
    benchmark that measures an older tree too says so by a fallback inside a try)."""
    known = modules()
    missing = []
    for path in [*sorted((ROOT / "tests").rglob("*.py")), *sorted((ROOT / "benchmarks").glob("*.py"))]:
        tree = ast.parse(path.read_text())
        guarded = {id(n) for t in ast.walk(tree) if isinstance(t, ast.Try) for h in t.handlers for n in ast.walk(h)}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").startswith("tiltload"):
                if node.module not in known and id(node) not in guarded:
                    missing.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.module}")
    assert missing == []


def test_the_check_finds_an_import_of_a_moved_module(tmp_path):
    source = "def f():\n    from ..campaign.case_system import case_system\n"
    node = next(n for n in ast.walk(ast.parse(source)) if isinstance(n, ast.ImportFrom))
    target = imported("tiltload.master.app.falsify.runner", tmp_path / "runner.py", node)
    assert target == "tiltload.master.app.campaign.case_system" and target not in modules()
