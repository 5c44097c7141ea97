"""Census of issue 49's generated bad inputs, class by class, against a given tiltload: every case run as the command
(or, for the API, a `python -c`-like call) in a session of its own with TMPDIR a fresh empty folder
(tests/support/isolated_case.py), and its outcome classified: one line with the right exit code, or what went wrong
(a traceback, "a bug", a hang, exit 0, another exit code, several lines, files left in TMPDIR, a process left alive,
no such command). The cases are the tests' own generators (tests/app/test_bad_input.py, test_bad_requirements.py),
written once into a folder; each tiltload runs the same files. Not a test: the outcome of another tiltload is a fact
to report, not to assert.

Run:  python benchmarks/bad_input_census.py generate DIR --fmus FMUS        (this tiltload's venv: writes DIR/cases.json)
      python benchmarks/bad_input_census.py run DIR --fmus FMUS --tiltload EXE --name NAME   (runs in EXE's interpreter)
      python benchmarks/bad_input_census.py table DIR NAME_BEFORE NAME_AFTER (markdown, one row per class)
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FMUS = "{FMUS}"  # the target's FMU folder, put in at run time
OUTCOMES = ["ok", "no such command", "traceback", "a bug", "hang", "crash (a signal)", "exit 0", "wrong exit code",
            "several lines", "left in TMPDIR", "process alive"]
EXCEPTION_LINE = re.compile(r"^[\w.]*(Error|Exception|Interrupt)\b[^:]*:")  # a traceback's last line (its head may be cut)


# ---- generate (this tiltload's venv: the generators are the tests') ----------------------------------------------------

def _generators():
    sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "tests" / "app")]
    import test_bad_input as inputs
    import test_bad_requirements as requirements

    return inputs, requirements


def generate(folder: Path, fmus: Path) -> list[dict]:
    """Every case as {class, label, argv | api, expect}, its files written under folder."""
    inputs, reqs = _generators()
    folder.mkdir(parents=True, exist_ok=True)
    cases: list[dict] = []

    def add(cls, label, argv=None, api=None, expect="2"):
        cases.append({"class": cls, "label": label, "argv": argv, "api": api, "expect": expect})

    # formulas of any size, non-finite numbers, sugar fields: check (a file, --formula, --explain) and tl.check
    (folder / "reqs").mkdir(exist_ok=True)
    log = reqs.write_log(folder / "reqs" / "run.mcap", _sine_log(), stop_time=2.0)
    for label, argv, _ in reqs.check_cases(folder / "reqs", log):
        add("formulas: size, non-finite, sugar (check)", label, argv)
    for label, formula in reqs.bad_formulas():
        add("formulas: the API (tl.check)", label, api=f"tl.check({str(log)!r}, formulas=[{('a: ' + formula)!r}])")
    picked = [c for c in reqs.bad_formulas() if c[0].startswith(("51 ", "30000 parentheses", "70,000", "constant 1e999",
                                                                  "horizon 1e308"))]
    for i, (label, formula) in enumerate(picked):  # a horizon past the run: refused by run and falsify, judged by a campaign
        path = folder / "reqs" / f"run{i}.yaml"
        path.write_text(f"requirements:\n  - name: a\n    formula: {json.dumps(formula)}\n")
        add("formulas: run, falsify, campaign", f"run --requirements: {label}",
            ["run", "--scenario", "fsi", "--stop-time", "2", "--fmus", FMUS, "--out", str(folder / "runs"), "--quiet",
             "--no-plots", "--no-log", "--requirements", str(path)])
        spec = folder / "reqs" / f"f{i}.toml"
        spec.write_text(reqs.FALSIFY.replace("{formula}", json.dumps(formula)))
        add("formulas: run, falsify, campaign", f"falsify: {label}",
            ["falsify", str(spec), "--out", str(folder / "reqs" / f"fo{i}"), "--fmus", FMUS, "--workers", "1"])
        if "1e308" in label:
            continue
        camp = folder / "reqs" / f"c{i}"
        camp.mkdir(exist_ok=True)
        (camp / "reqs.yaml").write_text(path.read_text())
        (camp / "c.toml").write_text(reqs.CAMPAIGN)
        add("formulas: run, falsify, campaign", f"campaign keep.requirements: {label}",
            ["campaign", str(camp / "c.toml"), "--fmus", FMUS, "--out", str(camp / "out"), "--workers", "1"])

    # every file opened as a file (the unreadable kind needs a refused open: only the test, which runs as root, has it)
    files = folder / "files"
    files.mkdir(exist_ok=True)
    for label, suffix, argv in inputs._file_commands(files):
        for kind, (path, _) in inputs._not_a_file_kinds(files, suffix).items():
            if kind != "unreadable":
                add("files opened as files", f"{label}: {kind}", [str(path) if a == "{}" else a for a in argv])

    # logs from other tools
    logs = folder / "logs"
    logs.mkdir(exist_ok=True)
    (logs / "b.json").write_text('{"metrics": {"ISE_x": 1.0}}')
    for label, (log_path, _) in inputs._foreign_logs(logs).items():
        add("logs from other tools", f"check, {label}", ["check", "--formula", "a: plant.x < 5", str(log_path)])
        add("logs from other tools", f"plot, {label}", ["plot", str(log_path), "--out", str(logs / "plots")])
        add("logs from other tools", f"compare, {label}", ["compare", str(log_path), str(logs / "b.json")])

    # output folders (a file, under a file) and stored parts (the read-only and full mounts: the test's own)
    out = folder / "outs"
    out.mkdir(exist_ok=True)
    camp, fals = out / "c.toml", out / "f.toml"
    camp.write_text(inputs.CAMPAIGN_SPEC)
    fals.write_text(inputs.FALSIFY_SPEC)
    (out / "a_file").write_text("x")
    for label, path in (("a file", out / "a_file"), ("under a file", out / "a_file" / "out")):
        add("output folders and stored parts", f"campaign --out {label}", ["campaign", str(camp), "--out", str(path),
                                                                           "--workers", "1", "--fmus", FMUS])
        add("output folders and stored parts", f"falsify --out {label}", ["falsify", str(fals), "--out", str(path),
                                                                          "--workers", "1", "--fmus", FMUS])
    for i, (label, part) in enumerate(inputs._bad_parts().items()):
        for command, spec in (("campaign", camp), ("falsify", fals)):
            if command == "campaign" and "index" in label:
                continue
            where = out / f"{command}_{i}"
            (where / "parts").mkdir(parents=True, exist_ok=True)
            name = where / "parts" / ("000000.parquet" if command == "falsify" else "r0+1-abc.parquet")
            _write_part(name, part)
            add("output folders and stored parts", f"{command}, a stored part: {label}",
                [command, str(spec), "--out", str(where), "--workers", "1", "--fmus", FMUS])

    # --fmus that is not a folder
    fm = folder / "fmus_option"
    fm.mkdir(exist_ok=True)
    (fm / "fmus.zip").write_bytes(b"PK")
    (fm / "c.toml").write_text(inputs.CAMPAIGN_SPEC)
    (fm / "f.toml").write_text(inputs.FALSIFY_SPEC)
    for command, argv in inputs.fmus_commands(fm).items():
        for label, (path, _) in inputs.not_a_folder_paths(fm).items():
            add("--fmus that is not a folder", f"{command} --fmus {label}", [*argv, f"--fmus={path}"])

    paths = folder / "paths"
    paths.mkdir(exist_ok=True)
    for label, argv, _ in inputs.path_option_cases(paths):
        add("path options by their kind", label, argv)
    for cls, label, argv, api, expect in inputs.surface_cases(folder / "surfaces", Path(FMUS)):
        add(cls, label, argv, api, expect)
    for case in issue62a_cases(folder, Path(FMUS)):
        add(*case)

    for label, api in api_field_cases():
        add("the public API's field types", label, api=api)

    # ---- issue 62, part B: the user's code in wrap; parts and controllers of searches and campaigns; names, newlines
    # and the design API (tests/app/test_bad_input_user_code.py)
    for cls, label, argv, api, expect in _user_code_generator().user_code_cases(folder / "user_code"):
        add(cls, label, argv, api, expect)
    return cases


def issue62a_cases(folder: Path, fmus: Path) -> list[tuple]:
    """Issue 62's classes (part A): baselines, API writers, b2b's case lists and sides, read-only places, reports that
    are their command's inputs (tests/app/bad_input_62a.py). The read-only disk is a tmpfs mounted beside the folder
    (not in it: each tiltload's copy of the folder would be writable); without mount rights those cases are left out."""
    import bad_input_62a as more

    log = more.log_with_metrics(folder / "issue62_log.mcap")
    cases = [*more.baseline_cases(folder / "baselines", log), *more.writer_cases(folder / "writers", log),
             *more.b2b_cases(folder / "b2b62", fmus), *more.report_cases(folder / "reports62", fmus)]
    readonly = more.readonly_mount(folder.parent / f"ro_{folder.name}")
    return cases + (more.readonly_cases(folder / "readonly62", fmus, readonly) if readonly is not None else [])


def api_field_cases() -> list[tuple[str, str]]:
    """Issue 62's "the public API checks less than the command line": numbers beyond a double's range, non-finite FMU
    parameters and misspelt keywords, given to the request objects (tests/app/test_api_field_types.py: the same, as
    property tests)."""
    huge = "10 ** 400"
    return [(f"Case(stop_time={huge})", f"tl.Case(stop_time={huge})"), (f"RunOptions(realtime={huge})", f"tl.RunOptions(realtime={huge})"),
            (f"FalsifyOptions(seconds={huge})", f"tl.FalsifyOptions(seconds={huge})"),
            (f"CampaignOptions(worker_timeout={huge})", f"tl.CampaignOptions(worker_timeout={huge})"),
            (f"Case(max_tilt={huge})", f"tl.Case(max_tilt={huge})"), (f"Case(seed={huge})", f"tl.Case(seed={huge})"),
            (f"Case(set={{plant.m_L: {huge}}})", f"tl.Case(set={{'plant.m_L': {huge}}})"),
            ("Case(set={plant.m_L: nan})", "tl.Case(set={'plant.m_L': float('nan')})"),
            ("Case(set={plant.m_L: -inf})", "tl.Case(set={'plant.m_L': float('-inf')})"),
            ("Case(set={plant.m_L: numpy nan})", "import numpy as np; tl.Case(set={'plant.m_L': np.float64('nan')})"),
            ("Case(stop_tme=3): a misspelt keyword", "tl.Case(stop_tme=3)"),
            ("RunOptions(no_plot=True): a misspelt keyword", "tl.RunOptions(no_plot=True)")]


def _user_code_generator():
    _generators()  # the tests' folders on sys.path
    import test_bad_input_user_code

    return test_bad_input_user_code


def _sine_log():
    import numpy as np

    t = np.arange(201) * 0.01
    return {"plant": (t, {"x": np.sin(t), "z": -2 + 0 * t})}


def _write_part(name: Path, part) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    if isinstance(part, bytes):
        name.write_bytes(part)
    else:
        pq.write_table(pa.Table.from_pylist(part) if part else pa.table({"run_id": pa.array([], pa.string())}), name)


# ---- run (in the target tiltload's interpreter) --------------------------------------------------------------------

def run(folder: Path, fmus: str, name: str, timeout_s: float, first: int = 0, only: list[str] | None = None) -> None:
    spec = importlib.util.spec_from_file_location("isolated_case", ROOT / "tests" / "support" / "isolated_case.py")
    isolated = importlib.util.module_from_spec(spec)
    sys.modules["isolated_case"] = isolated  # its dataclass looks itself up there
    spec.loader.exec_module(isolated)
    cases = json.loads((folder / "cases.json").read_text())
    # each tiltload on its own copy of the files (cp -a keeps the FIFOs): what one tiltload wrote (a results folder, a
    # file where a FIFO was) must not change the next one's cases
    copy = folder.parent / f"{folder.name}_{name}"
    if not copy.exists():
        subprocess.run(["cp", "-a", str(folder), str(copy)], check=True)
    cases = json.loads(json.dumps(cases).replace(str(folder), str(copy)))
    cwd = folder / f"cwd_{name}"
    cwd.mkdir(exist_ok=True)
    results_file = f"results_{name}.jsonl" if not first else f"results_{name}.from{first}.jsonl"
    with open(folder / results_file, "a" if only else "w") as results:  # --only: added to what ran before
        for i, case in enumerate(cases):
            if i < first or (only and not case["class"].startswith(tuple(only))):
                continue
            if case["api"] is not None:
                code = case["api"].replace(FMUS, fmus)
                call = lambda c=code: isolated.api_call(lambda: exec(c, {"tl": __import__("tiltload")}))  # noqa: E731, S102
            else:
                argv = [a.replace(FMUS, fmus) for a in case["argv"]]
                call = lambda a=argv: isolated.tiltload_entry(a)  # noqa: E731
            outcome = isolated.run_isolated(call, timeout_s=timeout_s, cwd=cwd)
            results.write(json.dumps({"i": i, "code": outcome.code, "err": outcome.err[-2000:], "files": outcome.left_files,
                                      "processes": outcome.left_processes}) + "\n")
            results.flush()


def classify(case: dict, result: dict) -> str:
    err, code = result["err"], result["code"]
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("campaign ", "falsify "))]
    if code is None:
        return "hang"
    command = (case["argv"] or [""])[0]
    if f"invalid choice: '{command}'" in err or "unrecognized arguments" in err or "module 'tiltload' has no attribute" in err:
        return "no such command"  # the command, an option of it or the API's name did not exist
    if "Traceback" in err or (lines and EXCEPTION_LINE.match(lines[-1]) and code == 1):
        return "traceback"
    if "a bug" in err:
        return "a bug"
    if code >= 128:
        return "crash (a signal)"
    if code == 0:
        return "exit 0"
    if case["expect"] == "2" and code != 2:
        return "wrong exit code"
    if len(lines) != 1:
        return "several lines"
    if result["files"]:
        return "left in TMPDIR"
    if result["processes"]:
        return "process alive"
    return "ok"


def table(folder: Path, before: str, after: str) -> str:
    cases = json.loads((folder / "cases.json").read_text())
    rows = {c["class"]: {before: Counter(), after: Counter()} for c in cases if not c.get("dropped")}  # in the cases' order
    totals = {before: Counter(), after: Counter()}
    for name in (before, after):
        seen = set()
        lines = [ln for f in sorted(folder.glob(f"results_{name}*.jsonl")) for ln in f.read_text().splitlines()]
        for line in lines:  # a case run by two runners (one started from a later case to finish sooner) counted once
            r = json.loads(line)
            if r["i"] in seen:
                continue
            seen.add(r["i"])
            if cases[r["i"]].get("dropped"):  # a case found not to be bad input after the runs (said why in the file)
                continue
            outcome = classify(cases[r["i"]], r)
            rows[cases[r["i"]]["class"]][name][outcome] += 1
            totals[name][outcome] += 1
    out = [f"| class | cases | {before}: ok | {before}: what went wrong | {after}: ok | {after}: what went wrong |",
           "| --- | ---: | ---: | --- | ---: | --- |"]
    for cls, by in [*rows.items(), ("**all**", totals)]:
        n = sum(by[after].values()) or sum(by[before].values())
        if not n:  # a class neither tiltload ran (run --only)
            continue
        cells = []
        for name in (before, after):
            wrong = ", ".join(f"{k} {v}" for k in OUTCOMES[1:] if (v := by[name][k]))
            cells += [str(by[name]["ok"]), wrong or "-"]
        out.append(f"| {cls} | {n} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    sub = p.add_subparsers(dest="what", required=True)
    g = sub.add_parser("generate")
    g.add_argument("folder", type=Path)
    g.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    r = sub.add_parser("run")
    r.add_argument("folder", type=Path)
    r.add_argument("--fmus", required=True)
    r.add_argument("--name", required=True)
    r.add_argument("--tiltload", help="the tiltload executable whose interpreter runs the cases (default: this one)")
    r.add_argument("--timeout", type=float, default=120.0, help="s per case; past it, a hang")
    r.add_argument("--first", type=int, default=0, help="start at this case (a second runner beside a first)")
    r.add_argument("--only", action="append", default=[], metavar="CLASS",
                   help="run only the classes starting with this (repeatable; results added to the name's file)")
    t = sub.add_parser("table")
    t.add_argument("folder", type=Path)
    t.add_argument("before")
    t.add_argument("after")
    args = p.parse_args()
    if args.what == "generate":
        cases = generate(args.folder.resolve(), args.fmus)
        (args.folder / "cases.json").write_text(json.dumps(cases, indent=0))
        print(f"{len(cases)} cases in {args.folder / 'cases.json'}")
    elif args.what == "run" and args.tiltload:  # the executable's own interpreter, from its first line
        python = Path(args.tiltload).read_text().splitlines()[0].removeprefix("#!").strip()
        return subprocess.call([python, __file__, "run", str(args.folder), "--fmus", args.fmus, "--name", args.name,
                                "--timeout", str(args.timeout), "--first", str(args.first),
                                *(f"--only={c}" for c in args.only)])
    elif args.what == "run":
        run(args.folder.resolve(), str(Path(args.fmus).resolve()), args.name, args.timeout, args.first, args.only)
    else:
        print(table(args.folder, args.before, args.after))
    return 0


if __name__ == "__main__":
    sys.exit(main())
