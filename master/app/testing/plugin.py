"""The tiltload pytest plugin (entry point `pytest11`: tiltload), for a user's controller repository: docs/api.md.

Fixtures: tiltload_fmus (the loop's FMUs, built once per session), tiltload_controller (a Python controller file or
class wrapped as an FMU once per session), tiltload_run (runs a case into the test's own folder), tiltload_case (one
case of the tiltload_cases marker) and tiltload_baseline (the test's recorded baseline: check a run against it, or
record it with --tiltload-update-baselines). Loaded in every pytest run once tiltload is installed, so it imports
nothing heavy until a test asks for one of its fixtures.
"""

from __future__ import annotations

import inspect
import itertools
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from ..api.result import Result

UPDATE = "--tiltload-update-baselines"
MARKER = "tiltload_cases"
REPORT = "--tiltload-report"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("tiltload", "tiltload: runs of the tilt-rotor loop and their baselines")
    group.addoption(UPDATE, action="store_true", default=False,
                    help="record each tiltload_baseline from this run's metrics instead of checking against it")
    group.addoption(REPORT, default=None, metavar="FILE",
                    help="write a self-contained HTML report of the session: a section per test, its runs' requirements "
                         "and figures (linked from the JUnit XML as the property tiltload_report)")
    group.addoption("--tiltload-fmus", default=None, metavar="DIR",
                    help="folder of the loop's FMUs, built there when missing or stale (default: the ini's tiltload_fmus)")
    parser.addini("tiltload_fmus", "folder of the loop's FMUs, relative to the rootdir (default: fmus)", default="fmus")
    parser.addini("tiltload_baselines", "folder of the recorded baselines, relative to the rootdir (default: baselines)",
                  default="baselines")
    parser.addini("tiltload_rtol", "relative tolerance of the recorded baselines (default 1e-6)", default="1e-6")
    parser.addini("tiltload_atol", "absolute tolerance of the recorded baselines (default 1e-12)", default="1e-12")


def pytest_configure(config: pytest.Config) -> None:
    if config.getoption(REPORT, None):
        from ..output_folder import writable_file
        from ..user_error import UserError

        try:  # checked as the commands' --report is, before any test runs (not a traceback when the session ends)
            writable_file(Path(config.getoption(REPORT)), REPORT, _session_inputs(config, Path(config.getoption(REPORT))))
        except UserError as err:
            raise pytest.UsageError(str(err)) from None
        config.pluginmanager.register(SessionReport(Path(config.getoption(REPORT)).resolve(), config), "tiltload-report")
    config.addinivalue_line("markers", f"{MARKER}(**axes): run the test once per combination of the axes' values "
                            "(e.g. scenario=['zse', 'lkf'], trajectory=[1, 2], seed=[1, 2]), each given to the test as "
                            "the tiltload_case fixture: the options of tiltload.run")


def cases(axes: Mapping[str, object]) -> list[dict[str, object]]:
    """Every combination of the axes' values (a value that is not a list or tuple is the only one of its axis)."""
    names = list(axes)
    values = [v if isinstance(v, (list, tuple)) else [v] for v in axes.values()]
    return [dict(zip(names, combo)) for combo in itertools.product(*values)]


def case_id(case: Mapping[str, object]) -> str:
    return ",".join(f"{k}={v}" for k, v in case.items()) or "default"


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    marker = metafunc.definition.get_closest_marker(MARKER)
    if marker is None:
        return
    if marker.args:
        raise pytest.UsageError(f"@pytest.mark.{MARKER} takes keywords (scenario=[...], trajectory=[...], seed=[...]), "
                                f"not {marker.args!r}")
    if "tiltload_case" not in metafunc.fixturenames:
        raise pytest.UsageError(f"{metafunc.definition.nodeid}: @pytest.mark.{MARKER} gives each case as the "
                                "tiltload_case fixture: add it to the test's arguments")
    combos = cases(marker.kwargs)
    metafunc.parametrize("tiltload_case", combos, ids=[case_id(c) for c in combos])


@pytest.fixture
def tiltload_case() -> dict[str, object]:
    """The case of this test: the options of tiltload.run (from the tiltload_cases marker; the default case without)."""
    return {}


@pytest.fixture(scope="session")
def tiltload_fmus(pytestconfig: pytest.Config) -> Path:
    """The loop's FMUs, built (or checked up to date) once per session: their folder."""
    from ..loop.fmus import build_all

    folder = pytestconfig.getoption("--tiltload-fmus") or pytestconfig.getini("tiltload_fmus")
    folder = (pytestconfig.rootpath / folder).resolve()
    build_all(folder, progress=lambda message: None)
    return folder


@pytest.fixture(scope="session")
def tiltload_controller(pytestconfig: pytest.Config, tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Path]:
    """controller(source, class_name=None, native=False) -> the controller FMU: a .fmu as is; a Python file, or a
    class, wrapped once per session: native False as `tiltload wrap` does (pythonfmu, into the session's temporary
    folder); True as `wrap --native` (the C FMU, a class that cannot be traced refused); None as `run --controller
    my_controller.py` (natively where it traces). Native ones are kept in the machine's cache (wrap/class_fmu.py)."""
    from ..wrap.sandbox import wrap_python

    made: dict[tuple[str, str | None, bool | None], Path] = {}
    where = tmp_path_factory.mktemp("tiltload_controllers")

    def controller(source: str | Path | type, class_name: str | None = None, native: bool | None = False) -> Path:
        if native not in (None, True, False):
            raise TypeError(f"native must be None, True or False, got {native!r:.40}")
        if isinstance(source, type):
            source, class_name = Path(inspect.getsourcefile(source) or ""), source.__name__
        path = (pytestconfig.rootpath / source).resolve()
        if path.suffix == ".fmu":
            return path
        key = (str(path), class_name, native)
        if key not in made:
            made[key] = (wrap_python(path, where / f"{path.stem}{'_' + class_name if class_name else ''}.fmu", class_name)
                         if native is False else _class_fmu(path, class_name, native))
        return made[key]
    return controller


def _class_fmu(path: Path, class_name: str | None, native: bool | None) -> Path:
    """The class's FMU by the route run and the API take (wrap/class_fmu.py: one wrapping, one cache); its errors the
    API's one line."""
    from ..api.errors import as_tiltload_errors
    from ..wrap.class_fmu import controller_fmu_of_file

    with as_tiltload_errors():
        return controller_fmu_of_file(path, native, field="tiltload_run controller", class_name=class_name)


@pytest.fixture(scope="session")
def tiltload_pool():
    """The session's executions (engine.lifecycle.ExecutionPool): tests running the same loop restart its FMUs."""
    from ...engine.lifecycle import ExecutionPool

    pool = ExecutionPool()
    yield pool
    pool.close()


@pytest.fixture
def tiltload_run(tiltload_fmus: Path, tiltload_controller: Callable[..., Path], tmp_path: Path,
                 request: pytest.FixtureRequest, tiltload_pool) -> Callable[..., Result]:
    """run(case=None, options=None, *, controller=..., native=False, **options) -> tiltload.Result: tiltload.run with
    the session's FMUs into this test's own folder, no figures (where the case and options leave them at their
    defaults); it takes every object tiltload.run takes, and a controller's file or class is wrapped once per session
    (tiltload_controller; native=True: its native C FMU, None: natively where it traces)."""
    from ..api.running import run

    def run_case(case=None, options=None, /, *, controller: object = None, native: bool | None = False,
                 **keywords: object) -> Result:
        if _session_wrapped(controller):
            controller = tiltload_controller(controller, native=native)
        ours = {"fmus": (case, tiltload_fmus), "out": (options, tmp_path), "no_plots": (options, True)}
        for key, (given, value) in ours.items():  # the session's, where neither a keyword nor an object set it
            if key not in keywords and (given is None or getattr(given, key) == _default(type(given), key)):
                keywords[key] = value
        result = run(case, options, pool=tiltload_pool, **({"controller": controller} if controller is not None else {}),
                     **keywords)
        request.node.stash.setdefault(RUNS, []).append(result)  # for --tiltload-report
        return result
    return run_case


def _session_wrapped(controller: object) -> bool:
    """A controller the session wraps itself (a Python file or class, an FMU's path relative to the rootdir); the rest
    (dlqr, mixed, a PythonController, None) goes to tiltload.run as it is, which takes them."""
    if isinstance(controller, type):
        return True
    return isinstance(controller, (str, Path)) and str(controller) not in ("dlqr", "mixed")


def _default(cls: type, name: str) -> object:
    from dataclasses import MISSING, fields

    found = next(f for f in fields(cls) if f.name == name)
    return found.default if found.default is not MISSING else None


RUNS = pytest.StashKey[list]()
BASELINES = pytest.StashKey[list]()  # each check of the test's tiltload_baseline: (what, file, outcome, failing comparison)


def _session_inputs(config: pytest.Config, report: Path) -> list[tuple[str, Path]]:
    """The session's inputs a report must not overwrite: each test file named, a test file or conftest.py inside a
    folder named, the ini file."""
    inputs = [("the ini file", Path(config.inipath))] if config.inipath else []
    for arg in config.args:
        given = Path(str(arg).split("::")[0])
        if given.is_file():
            inputs.append(("a test file of the session", given))
        elif given.is_dir() and report.resolve().is_relative_to(given.resolve()) and report.suffix == ".py":
            inputs.append(("a Python file among the session's tests", report))
    return inputs


class SessionReport:
    """--tiltload-report FILE: each test's runs, baselines and outcome, written as one HTML report when the session ends;
    the runs' logs and the files their replay commands name copied beside it (<FILE's stem>_files/), since pytest
    deletes its temporary folders after three sessions."""

    def __init__(self, path: Path, config: pytest.Config | None = None) -> None:
        self.path = path
        self.records: dict[str, object] = {}
        xml = getattr(config.option, "xmlpath", None) if config is not None else None
        # the JUnit XML's link to a test's section: relative to the XML's folder (else to the rootdir), never the
        # runner's absolute path, so that it holds where CI keeps the two side by side
        self._links_from = Path(xml).resolve().parent if xml else config.rootpath if config is not None else path.parent

    def _record(self, item: pytest.Item):
        import os

        from ..evidence.pytest_report import TestRecord

        if item.nodeid not in self.records:
            self.records[item.nodeid] = TestRecord(item.nodeid)
            link = Path(os.path.relpath(self.path, self._links_from)).as_posix()
            item.user_properties.append(("tiltload_report", f"{link}#test-{len(self.records)}"))  # the JUnit XML's link
        return self.records[item.nodeid]

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(self, item: pytest.Item, call):
        outcome = yield
        report = outcome.get_result()
        rec = self._record(item)
        rec.runs = list(item.stash.get(RUNS, []))
        rec.baselines = _baselines(item.stash.get(BASELINES, []), item.config.rootpath)
        if report.failed:
            rec.outcome = "FAIL" if report.when == "call" else "ERROR"
            said = call.excinfo.exconly() if call.excinfo is not None else str(report.longreprtext)
            rec.failure = (said.strip().splitlines() or [""])[0][:500]
        elif report.when == "call" and rec.outcome is None:
            rec.outcome = "PASS" if report.passed else None

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        from ..evidence.pytest_report import write_pytest_report

        if self.records:
            records = list(self.records.values())
            kept = self.path.parent / f"{self.path.stem}_files"
            factory = getattr(session.config, "_tmp_path_factory", None)  # pytest's own: where tmp_path folders are
            tmp = factory.getbasetemp() if factory is not None else None
            for k, rec in enumerate(records):
                rec.runs = [_kept(run, kept / f"test-{k + 1}", tmp) for run in rec.runs]
            write_pytest_report(records, self.path, f"pytest session in {session.config.rootpath.name}")
            session.config.get_terminal_writer().line(f"tiltload report: {self.path}")


def _baselines(checked: list, root: Path) -> list:
    """The report's view of a test's baseline checks: BaselineOutcome, a failing one with its comparison's table and
    figures (the report the comparison shows in a notebook: api.rich_display)."""
    from ..api.rich_display import comparison_report, signal_comparison_report
    from ..evidence.pytest_report import BaselineOutcome

    out = []
    for what, path, outcome, comparison in checked:
        shown = Path(path).relative_to(root) if Path(path).is_relative_to(root) else Path(path)
        tables, figures = (), ()
        if comparison is not None:
            page = comparison_report(comparison) if what == "metrics" else signal_comparison_report(comparison)
            tables, figures = tuple(page.tables), tuple(page.figures)
        out.append(BaselineOutcome(what, str(shown), outcome, tables, figures))
    return out


def _kept(run, folder: Path, tmp: Path | None):
    """The run as the report keeps it: its log and every file under pytest's temporary folder its replay command names
    copied into folder, the command and the log naming the copies (the command's output folder: folder)."""
    import dataclasses
    import shlex
    import shutil

    if tmp is None:
        return run
    tmp = Path(tmp).resolve()
    folder.mkdir(parents=True, exist_ok=True)

    def kept(path: Path) -> Path:
        if path.is_dir():
            return folder
        copy = folder / path.name
        if path.is_file() and not copy.exists():
            shutil.copy2(path, copy)
        return copy

    words = []
    for word in shlex.split(run.command):
        path = Path(word)
        words.append(str(kept(path)) if path.is_absolute() and path.resolve().is_relative_to(tmp) else word)
    log = run.log
    if log is not None and Path(log).resolve().is_relative_to(tmp) and Path(log).is_file():
        log = kept(Path(log))
    return dataclasses.replace(run, command=shlex.join(words), log=log)


def _baseline_name(node: pytest.Item) -> str:
    return re.sub(r"[^A-Za-z0-9._=,+-]", "_", node.name)


class Baseline:
    """The recorded baseline of one test: check(result) compares a run with it (or records it with
    --tiltload-update-baselines)."""

    def __init__(self, path: Path, update: bool, nodeid: str, rtol: float, atol: float, outcomes: list | None = None) -> None:
        self.path, self.update, self.nodeid, self.rtol, self.atol = path, update, nodeid, rtol, atol
        self.outcomes = outcomes if outcomes is not None else []  # (what, file, outcome, failing comparison): the report's

    def _said(self, what: str, path: Path, outcome: str, comparison: object = None) -> None:
        self.outcomes.append((what, path, outcome, comparison))

    def check(self, result: Result, rtol: float | None = None, atol: float | None = None) -> None:
        """Record (with --tiltload-update-baselines, or rtol / atol to record) or compare; a report-like failure."""
        __tracebackhide__ = True
        from ..api.comparing import save_baseline
        from .assertions import assert_matches_baseline

        hint = f'pytest {UPDATE} "{self.nodeid}"'
        if self.update:
            save_baseline(result, self.path, rtol=self.rtol if rtol is None else rtol, atol=self.atol if atol is None else atol)
            self._said("metrics", self.path, "recorded")
            return
        if not self.path.is_file():
            self._said("metrics", self.path, "none recorded")
            pytest.fail(f"no baseline recorded for {self.nodeid} ({self.path}): record it with {hint}", pytrace=False)
        try:
            assert_matches_baseline(result, self.path, rtol=rtol, atol=atol, update_hint=hint)
            self._said("metrics", self.path, "PASS")
            return
        except AssertionError as err:
            report = str(err)
            self._said("metrics", self.path, "FAIL", getattr(err, "comparison", None))
        # failed outside the except clause: inside it, pytest would print the report twice ("During handling of the
        # above exception, another exception occurred")
        pytest.fail(report, pytrace=False)

    @property
    def signals_path(self) -> Path:
        """The test's signal baseline: beside its metrics baseline, .parquet."""
        return self.path.with_suffix(".parquet")

    def check_signals(self, result: Result, signals, tolerances=None, **flags: float | None) -> None:
        """Record these signals (with --tiltload-update-baselines) or check each inside its tolerance tube around the
        recorded ones (tolerances: a file or {"default": ..., "signals": ...}; abs, rel, lead, lag for every signal)."""
        __tracebackhide__ = True
        from ..api.signal_comparing import save_signal_baseline
        from .assertions import assert_signals_match

        hint = f'pytest {UPDATE} "{self.nodeid}"'
        if self.update:
            save_signal_baseline(result, self.signals_path, signals, tolerances=tolerances)
            self._said("signals", self.signals_path, "recorded")
            return
        if not self.signals_path.is_file():
            self._said("signals", self.signals_path, "none recorded")
            pytest.fail(f"no signal baseline recorded for {self.nodeid} ({self.signals_path}): record it with {hint}",
                        pytrace=False)
        try:
            assert_signals_match(result, self.signals_path, signals=None if isinstance(signals, str) else signals,
                                 tolerances=tolerances, update_hint=hint, **flags)
            self._said("signals", self.signals_path, "PASS")
        except AssertionError as err:
            self._said("signals", self.signals_path, "FAIL", getattr(err, "comparison", None))
            pytest.fail(str(err), pytrace=False)


@pytest.fixture
def tiltload_baseline(request: pytest.FixtureRequest) -> Baseline:
    """This test's baseline file: <tiltload_baselines>/<test file's stem>/<test name>.json (its signal baseline, .parquet
    beside it)."""
    config = request.config
    folder = config.rootpath / config.getini("tiltload_baselines") / Path(request.node.path).stem
    return Baseline(folder / f"{_baseline_name(request.node)}.json", config.getoption(UPDATE), request.node.nodeid,
                    float(config.getini("tiltload_rtol")), float(config.getini("tiltload_atol")),
                    request.node.stash.setdefault(BASELINES, []))


