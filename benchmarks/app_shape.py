"""Issue 61's before/after figures of the application's shape, measured the same way on any tree:
modules at the top of master/app/, lines of master/app/, exception classes (and the modules defining them) in the
whole project, and the modules over 400 lines.

    python benchmarks/app_shape.py [--root TREE]

Exception classes are found by importing every module of the installed tiltload and keeping the classes defined in it
that derive from BaseException (run it with TREE's own interpreter).
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import pkgutil
from pathlib import Path

PACKAGES = ("master", "plant_fmu", "controller_fmu", "sensor_fmu", "scenario_fmu", "native_fmu", "formation")


def exception_classes() -> dict[str, list[str]]:
    import tiltload

    found: dict[str, list[str]] = {}
    for package in PACKAGES:
        root = importlib.import_module(f"tiltload.{package}")
        for info in pkgutil.walk_packages(root.__path__, f"tiltload.{package}."):
            if info.name.endswith(("__main__", ".serve", ".wrapped_slave")) or ".c." in info.name:  # a template, run inside an FMU
                continue
            module = importlib.import_module(info.name)
            for name, obj in vars(module).items():
                if inspect.isclass(obj) and issubclass(obj, BaseException) and obj.__module__ == info.name:
                    found.setdefault(info.name, []).append(name)
    del tiltload
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[1])
    args = parser.parse_args()
    app = args.root / "master" / "app"
    top = sorted(p.name for p in app.iterdir() if p.suffix in (".py", ".c") and p.name != "__init__.py")
    lines = sum(len(p.read_text().splitlines()) for p in app.rglob("*.py"))
    long = [(str(p.relative_to(args.root)), n) for p in sorted(args.root.glob("*/**/*.py"))
            if not {"tests", "benchmarks", ".git", "docs"} & set(p.parts)
            and (n := len(p.read_text().splitlines())) > 400]
    classes = exception_classes()
    print(f"modules at the top of master/app/: {len(top)} ({sum(n.endswith('.py') for n in top)} Python, "
          f"{sum(n.endswith('.c') for n in top)} C)")
    print(f"lines of master/app/ (Python): {lines}")
    print(f"exception classes: {sum(map(len, classes.values()))} in {len(classes)} modules")
    print(f"modules over 400 lines: {', '.join(f'{p} ({n})' for p, n in long) or 'none'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
