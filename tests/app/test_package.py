"""The installable package: every module and every file the build reads is in the wheel, and the wheel alone builds
the FMUs and runs the loop from a folder outside the repository (slow: it builds the wheel and every FMU)."""

from __future__ import annotations

import fnmatch
import os
import shutil
import site
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from support import ROOT

PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
SETUPTOOLS = PYPROJECT["tool"]["setuptools"]


def _tracked(folder: str) -> list[Path]:
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", folder], cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout.split()
    return [ROOT / f for f in out]


def _package_of(path: Path) -> tuple[str, str] | None:
    """(package name, path inside it) of a repository file, by the package-dir mapping."""
    rel = path.relative_to(ROOT)
    best = None
    for package in SETUPTOOLS["packages"]:
        root = SETUPTOOLS["package-dir"].get(package)
        if root is None:  # a subpackage: its folder under its top package's
            top = max((p for p in SETUPTOOLS["package-dir"] if package.startswith(p + ".")), key=len)  # tiltload.master, not tiltload
            root = SETUPTOOLS["package-dir"][top] + "/" + package[len(top) + 1:].replace(".", "/")
        if rel.parent.as_posix() == root or rel.parent.as_posix().startswith(root + "/"):
            inner = rel.relative_to(root).as_posix()
            if best is None or len(root) > len(best[2]):
                best = (package, inner, root)
    return None if best is None else best[:2]


def test_every_python_package_of_the_repository_is_in_the_wheel():
    """A folder with an __init__.py that the package list forgets is missing from the wheel (commands/ was)."""
    listed = set(SETUPTOOLS["packages"])
    found = set()
    for top, folder in SETUPTOOLS["package-dir"].items():
        for init in _tracked(folder):
            if init.name == "__init__.py":
                rel = init.parent.relative_to(ROOT / folder).as_posix()
                found.add(top if rel == "." else f"{top}.{rel.replace('/', '.')}")
    assert found - listed == set(), "packages missing from pyproject.toml's [tool.setuptools] packages"
    assert listed - found == set(), "listed packages with no folder"


def test_every_data_file_the_packages_hold_is_package_data():
    """Each non-Python file under a package folder (C sources, shipped designs) matches a package-data pattern."""
    data = SETUPTOOLS["package-data"]
    missing = []
    for folder in SETUPTOOLS["package-dir"].values():
        for f in _tracked(folder):
            if f.suffix == ".py" or f.name == "__init__.py":
                continue
            package, inner = _package_of(f)
            patterns = [*data.get("*", []), *data.get(package, [])]
            if not any(fnmatch.fnmatch(inner, p) for p in patterns):
                missing.append(f.relative_to(ROOT).as_posix())
    assert missing == []


def _clean_copy(dest: Path) -> Path:
    """The working tree's files as git knows them (no build/ or egg-info left by an earlier in-tree build)."""
    for f in _tracked("."):
        if f.is_file():
            target = dest / f.relative_to(ROOT)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(f, target)
    return dest


def _venv_with_dependencies(folder: Path) -> Path:
    """A fresh virtual environment that sees this interpreter's installed dependencies but no tiltload: their
    site-packages folders are added as plain path entries, so the .pth files there (an editable tiltload) never
    run. Nothing is downloaded."""
    subprocess.run([sys.executable, "-m", "venv", str(folder)], check=True)
    purelib = subprocess.run([str(folder / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    # and the site-packages folders this interpreter reaches through a .pth of its own (a venv layered on another)
    layered = [p for p in sys.path if Path(p).name == "site-packages"]
    dirs = [d for d in dict.fromkeys([*site.getsitepackages(), site.getusersitepackages(), *layered]) if Path(d).is_dir()]
    Path(purelib, "tiltload_test_dependencies.pth").write_text("\n".join(dirs) + "\n")
    return folder / "bin" / "python"


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The wheel built from a clean copy of the tree, installed into a fresh virtual environment: its python."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = _clean_copy(tmp / "src")
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(tmp / "dist"), str(src)],
                           capture_output=True, text=True, timeout=600)
    assert built.returncode == 0, built.stderr[-2000:]
    wheel = next((tmp / "dist").glob("tiltload-*.whl"))
    python = _venv_with_dependencies(tmp / "venv")
    put = subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--no-deps", "--no-index", str(wheel)],
                         capture_output=True, text=True, timeout=300)
    assert put.returncode == 0, put.stderr[-2000:]
    return python


@pytest.mark.slow
def test_the_wheel_builds_the_fmus_and_runs_the_loop_outside_the_repository(installed, tmp_path):
    where = tmp_path / "elsewhere"
    where.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "TILTLOAD_CACHE")}
    env["TILTLOAD_CACHE"] = str(tmp_path / "empty-cache")  # as a new user has: nothing cached
    site_dir = installed.parents[1]
    origin = subprocess.run([str(installed), "-c", "import tiltload.master, tiltload.controller_fmu.fmu.build as b; "
                             "print(tiltload.master.__file__); print(b.__file__)"], capture_output=True, text=True, cwd=where,
                            env=env)
    assert origin.returncode == 0, origin.stderr
    assert all(Path(line).is_relative_to(site_dir) for line in origin.stdout.split()), origin.stdout  # not the repository

    tiltload = str(installed.parent / "tiltload")
    build = subprocess.run([tiltload, "build"], capture_output=True, text=True, cwd=where, env=env, timeout=1800)
    assert build.returncode == 0, build.stderr[-3000:]
    assert len(list((where / "fmus").glob("*.fmu"))) == 9, build.stdout
    said = build.stdout + build.stderr
    assert "synthesizing the mixed" not in said and said.count("the shipped one") == 3  # the designs came with it
    run = subprocess.run([tiltload, "run", "--stop-time", "2", "--quiet"], capture_output=True, text=True, cwd=where,
                         env=env, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "ISE(x)" in run.stdout and (where / "runs" / "zse_traj1_mixed_seed1_t2s.mcap").is_file()
    assert len(list((where / "runs").glob("*.png"))) == 7


@pytest.mark.slow
def test_the_example_repository_s_suite_runs_on_the_wheel(installed, fmus, tmp_path):
    """The plugin comes with the wheel (its pytest11 entry point): the example controller repository's suite, its
    controller changed, passes one test and fails its two baseline tests with a report, in JUnit XML."""
    from support import example_repo

    repo = example_repo.copy(tmp_path / "repo")
    example_repo.regress(repo)
    built = shutil.copytree(fmus, tmp_path / "fmus")  # the repository's FMUs, checked (and rebuilt if stale) by the wheel
    junit = tmp_path / "junit.xml"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    ran = example_repo.run_suite(installed, repo, built, junit, env)
    assert ran.returncode == 1, ran.stdout[-3000:] + ran.stderr[-2000:]
    results = example_repo.outcomes(junit)
    passed = [name for name, failure in results.items() if failure is None]
    failed = {name: failure for name, failure in results.items() if failure is not None}
    assert passed == ["test_the_controller_tracks_the_circle_closely"] and len(failed) == 2, results
    for message in failed.values():
        for words in example_repo.REPORT_WORDS[:4]:
            assert words in message or "seed 2" in message, message
    (tmp_path / "failure.txt").write_text(next(iter(failed.values())))


@pytest.mark.slow
def test_the_example_repository_s_suite_passes_on_the_wheel_as_written(installed, fmus, tmp_path):
    """The example controller repository as shipped (its controller designed with tl.plant and tl.design) passes its
    suite on the wheel in a fresh virtual environment, outside the repository: its imports reach only what installs."""
    from support import example_repo

    repo = example_repo.copy(tmp_path / "repo")
    built = shutil.copytree(fmus, tmp_path / "fmus")
    junit = tmp_path / "junit.xml"
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    ran = example_repo.run_suite(installed, repo, built, junit, env)
    assert ran.returncode == 0, ran.stdout[-3000:] + ran.stderr[-2000:]
    results = example_repo.outcomes(junit)
    assert len(results) == 3 and all(failure is None for failure in results.values()), results
    where = subprocess.run([str(installed), "-c", "import tiltload as tl; print(tl.plant.__file__, tl.design.__file__)"],
                           capture_output=True, text=True, cwd=repo, env=env)
    assert where.returncode == 0, where.stderr
    assert all(Path(f).is_relative_to(installed.parents[1]) for f in where.stdout.split()), where.stdout  # the wheel's
