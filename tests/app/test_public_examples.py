"""The shipped examples use only the public namespace: every Python file under docs/examples/ (the example controller
repository included) imports nothing of tiltload but `tiltload` (its public names), `tiltload.plant`, `tiltload.design`
and `tiltload.testing`, and nothing of the repository's own folders (plant_fmu, master, ...: there only in a clone);
docs/design_api.md's examples run; the mixed example flies."""

from __future__ import annotations

import ast
import re

import numpy as np
import pytest
import tiltload as tl
from support import ROOT
from tiltload.master.app.cli import main

PUBLIC_MODULES = {"tiltload", "tiltload.plant", "tiltload.design", "tiltload.testing"}
# plant_fmu, master, ...: tiltload's subpackages, importable bare only from a clone's root
REPOSITORY_FOLDERS = {p.name for p in ROOT.iterdir() if (p / "__init__.py").is_file()} - {"tiltload"}
EXAMPLES = sorted((ROOT / "docs" / "examples").rglob("*.py"))


def internal_uses(source: str) -> list[str]:
    """What a module's source reaches of tiltload beyond its public namespace, or of the repository's folders."""
    tree = ast.parse(source)
    found, aliases = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                top = a.name.split(".")[0]
                if (top == "tiltload" and a.name not in PUBLIC_MODULES) or top in REPOSITORY_FOLDERS:
                    found.append(f"import {a.name}")
                elif a.name == "tiltload":
                    aliases.add(a.asname or "tiltload")
        elif isinstance(node, ast.ImportFrom):
            module, top = node.module or "", (node.module or "").split(".")[0]
            if node.level or top in REPOSITORY_FOLDERS or (top == "tiltload" and module not in PUBLIC_MODULES):
                found.append(f"from {'.' * node.level}{module} import ...")
            elif module == "tiltload":
                found += [f"from tiltload import {a.name}" for a in node.names if a.name not in (*tl.__all__, "testing")]
    for node in ast.walk(tree):  # tl.master..., tl.plant_fmu...: an attribute of the package that is not public
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases:
            if node.attr not in (*tl.__all__, "testing"):
                found.append(f"{node.value.id}.{node.attr}")
    return found


def test_the_scan_finds_each_way_of_reaching_an_internal_module():
    bad = """
import tiltload.master.app.loop.thesis
from tiltload.controller_fmu.design.estimator_setup import augmented_model
from plant_fmu.trim import hover_trim
import master
from tiltload import plant_fmu
import tiltload as tl
tl.controller_fmu.design
from . import sibling
"""
    assert len(internal_uses(bad)) == 7
    good = ("import numpy as np\nimport tiltload as tl\nfrom tiltload.testing import assert_metrics_below\n"
            "tl.plant.trim(); tl.design.dlqr()\n")
    assert internal_uses(good) == []


def test_there_are_examples_to_scan():
    names = {p.relative_to(ROOT).as_posix() for p in EXAMPLES}
    assert {"docs/examples/hover_lqr.py", "docs/examples/controller_repo/controller/hover_lqr.py",
            "docs/examples/controller_repo/tests/test_hover_lqr.py"} <= names


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_each_example_imports_only_the_public_namespace(path):
    assert internal_uses(path.read_text()) == []


def test_the_examples_of_docs_design_api_md_run(tmp_path, monkeypatch, capsys):
    page = (ROOT / "docs" / "design_api.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", page, flags=re.S)
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    for block in blocks:
        assert internal_uses(block) == [], block
        exec(compile(block, "docs/design_api.md", "exec"), {})


@pytest.mark.parametrize("delay", [False, True])
def test_the_mixed_example_holds_the_circle_as_the_shipped_mixed_controller_does(delay, fmus, tmp_path):
    """docs/examples/hover_mixed.py (tl.design.mixed, wrapped): 3 s of the circle, with the loop's one-tick delay its
    own delay-aware gain; its ISE within 10 % of the shipped mixed controller's (which adds the feedforward (3.18))."""
    fmu = tmp_path / "hover_mixed.fmu"
    assert main(["wrap", str(ROOT / "docs" / "examples" / "hover_mixed.py"), "--out", str(fmu)]) == 0
    options = {"scenario": "fsi", "trajectory": 1, "stop_time": 3, "fmus": str(fmus), "no_plots": True, "delay": delay}
    ours = tl.run(controller=str(fmu), set={"controller.delay_ticks": 1} if delay else {}, out=str(tmp_path / "ours"), **options)
    shipped = tl.run(controller="mixed", out=str(tmp_path / "shipped"), **options)
    for key in ("ISE(x)", "ISE(y)", "ISE(z)"):
        assert np.isfinite(ours.metrics[key]) and abs(ours.metrics[key] / shipped.metrics[key] - 1) < 0.10, (key, ours.metrics)
