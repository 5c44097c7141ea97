"""Issue 62, part B: generated bad input of three classes, each case one line and exit 2 (TiltloadError from the API),
nothing left in TMPDIR, no process alive, no hang (tests/support/isolated_case.py), as issue 49's classes are checked;
the census (benchmarks/bad_input_census.py) runs the same generator before and after.

- the user's code in `wrap` (both routes and the API's Python controllers): sys.exit() and KeyboardInterrupt
  anywhere, os._exit and signals, loops and long C calls, memory, os.chdir, attribute names that are not C's, I/O in a
  traced step, NUL bytes;
- what a search or a campaign stores and runs: a file (FIFO, link) where parts/ goes, a controller file that is not
  an FMU;
- small: requirement names with control characters, a newline in a value quoted into an error line, the design API
  at sample times whose model overflows."""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import pytest
from test_bad_input import CAMPAIGN_SPEC, FALSIFY_SPEC

WRAP = "wrap: the user's code ends or stalls tiltload"
RUNS = "falsify and campaign: parts, controllers"
SMALL = "names, newlines, the design API"
FMUS = "{FMUS}"  # the census's placeholder for the FMU folder (the tests put their own in)

_PORTS = "    inputs = ['x_ref', 'exact_x']\n"
_STEP = "    def step(self, t, i):\n        return self.k * (i['x_ref'] - i['exact_x']), 0.0, 0.0, 0.0\n"
_INIT = "    def __init__(self):\n        self.k = 1.0\n"
_BACKTRACK = "re.match(r'(a+)+$', 'a' * 64 + 'b')"  # minutes in re's C loop, which no signal handler interrupts


def _cls(top: str = "", init: str = "        self.k = 1.0\n", step: str = "") -> str:
    """A controller file: imports and top-level code, __init__'s body, step's first lines (then its command)."""
    head = "import ctypes, os, re, signal, socket, subprocess, sys, time\nimport numpy as np\n" + top
    body = "class C:\n" + _PORTS + "    def __init__(self):\n" + init
    return head + body + "    def step(self, t, i):\n" + step + "        return self.k * (i['x_ref'] - i['exact_x']), 0.0, 0.0, 0.0\n"


def wrap_sources() -> dict[str, tuple[str, str]]:
    """label -> (where the misdeed is: top, init or step; the file's text)."""
    top = {"sys.exit()": "sys.exit()\n", "sys.exit(0)": "sys.exit(0)\n", "raise SystemExit(5)": "raise SystemExit(5)\n",
           "raise KeyboardInterrupt": "raise KeyboardInterrupt\n", "os._exit(0)": "os._exit(0)\n",
           "SIGKILL to itself": "os.kill(os.getpid(), signal.SIGKILL)\n", "a loop without end": "while True:\n    pass\n",
           "a long C call (regex backtracking)": f"{_BACKTRACK}\n", "16 GiB at import (the limit: 4 GiB)": "x = bytearray(16 << 30)\n"}
    init = {"sys.exit()": "        sys.exit()\n", "sys.exit('bye')": "        sys.exit('bye')\n",
            "raise KeyboardInterrupt": "        raise KeyboardInterrupt\n", "os._exit(3)": "        os._exit(3)\n",
            "SIGSEGV to itself": "        os.kill(os.getpid(), signal.SIGSEGV)\n",
            "a long C call (regex backtracking)": f"        {_BACKTRACK}\n        self.k = 1.0\n",
            "a 16 GiB array (the limit: 4 GiB)": "        self.big = np.empty(2 << 30)\n        self.k = 1.0\n",
            "a name with a dash": "        setattr(self, 'a-b', 1.0)\n        self.k = 1.0\n",
            "a name with a space": "        self.__dict__['gain x'] = 1.0\n        self.k = 1.0\n",
            "a name starting with a digit": "        setattr(self, '1k', 1.0)\n        self.k = 1.0\n",
            "a name with a quote": "        setattr(self, 'k\"', 1.0)\n        self.k = 1.0\n",
            "a name not ASCII": "        setattr(self, 'gain\u00e9', 1.0)\n        self.k = 1.0\n",
            "two attributes, one FMU name": "        self.K = [1.0, 2.0]\n        self.K_0 = 3.0\n        self.k = 1.0\n"}
    step = {"sys.exit()": "        sys.exit()\n", "raise KeyboardInterrupt": "        raise KeyboardInterrupt\n",
            "a file appended to": "        with open('trace.log', 'a') as f:\n            f.write('x')\n",
            "a write swallowed by except": "        try:\n            open('w.txt', 'w').write('x')\n        except Exception:\n"
                                           "            pass\n",
            "a file read": "        data = open(__file__).read()\n",
            "np.savetxt": "        np.savetxt('out.txt', [1.0])\n",
            "a file removed": "        if os.path.exists('none'):\n            pass\n        os.remove('nothing-here')\n",
            "a process started": "        subprocess.run(['true'])\n",
            "a socket": "        socket.socket().connect(('127.0.0.1', 9))\n",
            "os._exit(0)": "        os._exit(0)\n"}
    out = {f"module: {k}": ("top", _cls(top=v)) for k, v in top.items()}
    out |= {f"__init__: {k}": ("init", _cls(init=v)) for k, v in init.items()}
    out |= {f"step: {k}": ("step", _cls(step=v)) for k, v in step.items()}
    out["a NUL byte at line 4"] = ("top", "class C:\n    inputs = ['x_ref']\n\n\0\n")
    return out


SLOW = ("a loop without end", "long C call")  # cut at the time limit: run on fewer routes


def _api(path: Path, native: str) -> str:
    """The API's route: the class imported as a user's script imports it, given to tl.Case."""
    return (f"import importlib.util as u, sys; s = u.spec_from_file_location('user_ctrl', {str(path)!r}); "
            "m = u.module_from_spec(s); sys.modules['user_ctrl'] = m; s.loader.exec_module(m); "
            f"tl.Case(controller=tl.PythonController(m.C, native={native}), fmus={FMUS!r})")


def user_code_cases(folder: Path) -> list[tuple[str, str, list[str] | None, str | None, str]]:
    """(class, label, argv or None, API code or None, the exit expected) of the three classes."""
    folder.mkdir(parents=True, exist_ok=True)
    cases = []
    for i, (label, (where, source)) in enumerate(wrap_sources().items()):
        path = folder / f"ctrl{i}.py"
        path.write_bytes(source.encode())
        slow = any(s in label for s in SLOW)
        traced = where == "step" or " name" in label  # a traced step, the numbers' names: what only --native has
        routes = [("wrap --native", ["--native"])] if traced or (slow and where == "init") else \
            [("wrap", [])] if slow else [("wrap", []), ("wrap --native", ["--native"])]
        for name, extra in routes:
            cases.append((WRAP, f"{name}: {label}", ["wrap", *extra, str(path), "--out", str(folder / f"w{i}.fmu")], None, "2"))
        if where in ("init", "step") and not slow and "16 GiB" not in label:
            for native in (["True"] if traced else ["True", "False"]):
                cases.append((WRAP, f"tl.Case(controller=..., native={native}): {label}", None, _api(path, native), "2"))
    return cases + _runs_cases(folder / "runs") + _small_cases(folder / "small")


def _not_fmus(folder: Path) -> dict[str, Path]:
    folder.mkdir(parents=True, exist_ok=True)
    files = {"a text file": ("notes.txt", b"a controller\n"), "garbage named .fmu": ("garbage.fmu", b"\x00garbage"),
             "an empty .fmu": ("empty.fmu", b""), "a Python file": ("ctrl.py", _cls().encode())}
    out = {}
    for label, (name, data) in files.items():
        (folder / name).write_bytes(data)
        out[label] = folder / name
    with zipfile.ZipFile(folder / "zip.fmu", "w") as z:
        z.writestr("readme.txt", "a zip, not an FMU")
    out["a zip without a model description"] = folder / "zip.fmu"
    with zipfile.ZipFile(folder / "md.fmu", "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription/>")
    out["a model description of nothing"] = folder / "md.fmu"
    return out


def _runs_cases(folder: Path) -> list[tuple[str, str, list[str] | None, str | None, str]]:
    folder.mkdir(parents=True, exist_ok=True)
    camp, fals = folder / "c.toml", folder / "f.toml"
    camp.write_text(CAMPAIGN_SPEC)
    fals.write_text(FALSIFY_SPEC)
    (folder / "a_file").write_text("x")
    cases = []
    kinds = {"a file": lambda p: p.write_text("x"), "a FIFO": lambda p: os.mkfifo(p),
             "a dangling link": lambda p: p.symlink_to(folder / "nowhere"), "a link to a file": lambda p: p.symlink_to(folder / "a_file")}
    for i, (label, make) in enumerate(kinds.items()):
        for command, spec in (("campaign", camp), ("falsify", fals)):
            out = folder / f"{command}{i}"
            out.mkdir(exist_ok=True)
            make(out / "parts")
            cases.append((RUNS, f"{command}: parts is {label}", [command, str(spec), "--out", str(out), "--workers", "1",
                                                                  "--fmus", FMUS], None, "2"))
    for i, (label, path) in enumerate(_not_fmus(folder / "controllers").items()):
        spec = folder / f"c{i}.toml"
        spec.write_text(CAMPAIGN_SPEC.replace('controllers = ["dlqr"]', f"controllers = [{json.dumps(str(path))}]"))
        if label == "a Python file":  # a campaign and a falsification wrap a class's file as run does (issue 65:
            continue  # test_plain_numpy.py)
        cases.append((RUNS, f"campaign controller: {label}", ["campaign", str(spec), "--out", str(folder / f"co{i}"),
                                                              "--workers", "1", "--fmus", FMUS], None, "2"))
        spec = folder / f"f{i}.toml"
        spec.write_text(FALSIFY_SPEC.replace("[base]\n", f"[base]\ncontroller = {json.dumps(str(path))}\n"))
        cases.append((RUNS, f"falsify controller: {label}", ["falsify", str(spec), "--out", str(folder / f"fo{i}"),
                                                             "--workers", "1", "--fmus", FMUS], None, "2"))
    return cases


def _small_cases(folder: Path) -> list[tuple[str, str, list[str] | None, str | None, str]]:
    import numpy as np
    from support.synthetic_log import write_log

    folder.mkdir(parents=True, exist_ok=True)
    t = np.arange(201) * 0.01
    log = write_log(folder / "a.mcap", {"plant": (t, {"x": np.sin(t), "z": -2 + 0 * t})}, stop_time=2.0)
    cases = []
    names = {"a trailing newline": "a\\n", "a carriage return": "a\\r", "a tab": "a\\tb", "an escape sequence": "a\\e[31m",
             "a leading newline": "\\na", "a NUL": "a\\0", "a line separator": "a\\u2028", "a DEL": "a\\x7f"}
    for i, (label, name) in enumerate(names.items()):
        path = folder / f"r{i}.yaml"
        path.write_text(f'requirements:\n  - name: "{name}"\n    formula: plant.x < 5\n')
        cases.append((SMALL, f"check: a requirement name with {label}", ["check", str(path), str(log)], None, "2"))
        cases.append((SMALL, f"check --explain: a requirement name with {label}", ["check", str(path), "--explain"], None, "2"))
    specs = {"falsify: a requirement name with a trailing newline": FALSIFY_SPEC.replace('name = "swing"', 'name = "swing\\n"'),
             "falsify: a search name with a trailing newline": FALSIFY_SPEC.replace('name = "amp"', 'name = "amp\\n"'),
             "falsify: a search target with a trailing newline": FALSIFY_SPEC.replace('"gust.amplitude"', '"gust.amplitude\\n"'),
             "campaign: a name with a trailing newline": CAMPAIGN_SPEC.replace('name = "small"', 'name = "small\\n"')}
    for i, (label, text) in enumerate(specs.items()):
        spec = folder / f"s{i}.toml"
        spec.write_text(text)
        command = label.partition(":")[0]
        cases.append((SMALL, label, [command, str(spec), "--out", str(folder / f"o{i}"), "--workers", "1", "--fmus", FMUS],
                      None, "2"))
    values = {"run --set with a newline": ["run", "--set", "plant.m_L=a\nb", "--stop-time", "1", "--no-log", "--fmus", FMUS],
              "run --stop-time with a newline": ["run", "--stop-time", "1\n2"],
              "run --controller with an escape sequence": ["run", "--controller", "pid\x1b[2J", "--fmus", FMUS],
              "wrap of a path with a newline": ["wrap", str(folder / "no\nsuch.py")],
              "compare --signals with a newline": ["compare", str(log), str(log), "--signals", "plant.x\nplant.y"],
              "check --formula with a carriage return": ["check", str(log), "--formula", "a: plant.nothing\r < 1"],
              "falsify of a spec path with a newline": ["falsify", str(folder / "no\nspec.toml")]}
    for label, argv in values.items():
        cases.append((SMALL, label, argv, None, "2"))
    api = {"tl.plant.linearize(dt=1000)": "tl.plant.linearize(dt=1000.0)",
           "tl.plant.linearize(dt=1e6)": "tl.plant.linearize(dt=1e6)",
           "tl.plant.linearize(dt=1e300)": "tl.plant.linearize(dt=1e300)",
           "tl.plant.linearize(dt=500, integral=True)": "tl.plant.linearize(dt=500.0, integral=True)",
           "tl.plant.linearize(dt=400, delay_ticks=1)": "tl.plant.linearize(dt=400.0, delay_ticks=1)",
           "tl.design.hinf(dt=10)": "tl.design.hinf(dt=10.0)",
           "tl.design.hinf(dt=100)": "tl.design.hinf(dt=100.0)",
           "tl.design.mixed(dt=1000)": "tl.design.mixed(dt=1000.0)",
           "tl.design.dlqr at dt=10": "tl.design.dlqr(tl.plant.linearize(dt=10.0, integral=True))",
           "tl.design.dlqr at dt=50": "tl.design.dlqr(tl.plant.linearize(dt=50.0, integral=True))"}
    for label, code in api.items():
        cases.append((SMALL, label, None, code, "2"))
    return cases


# ---- the tests ---------------------------------------------------------------------------------------------------

def _run_all(cases, fmus: Path) -> list[str]:
    import tiltload as tl
    from support.isolated_case import api_call, run_isolated, tiltload_entry

    problems = []
    for cls, label, argv, api, _ in cases:
        if argv is not None:
            argv = [a.replace(FMUS, str(fmus)) for a in argv]
            outcome = run_isolated(lambda a=argv: tiltload_entry(a), timeout_s=240)
        else:
            code = api.replace(FMUS, str(fmus))
            outcome = run_isolated(lambda c=code: api_call(lambda: exec(c, {"tl": tl})), timeout_s=240)  # noqa: S102
        lines = [ln for ln in outcome.err.splitlines() if ln.strip() and not ln.startswith(("campaign ", "falsify "))]
        if outcome.left_behind:
            lines.append(outcome.left_behind)
        if outcome.code != 2 or len(lines) != 1 or "a bug" in lines[0] or "Traceback" in lines[0]:
            problems.append(f"{cls}: {label}: exit {outcome.code}: {lines[-3:]}")
    return problems


@pytest.mark.slow
def test_the_users_code_in_wrap_cannot_end_or_stall_tiltload(fmus, tmp_path, monkeypatch):
    """Each case one line naming the problem, exit 2; the time limit here 2 s (a loop, a long C call: cut by the
    child's timer or the watchdog)."""
    from tiltload.master.app.wrap import trace

    monkeypatch.setattr(trace, "TIME_LIMIT_S", 2.0)
    monkeypatch.chdir(tmp_path)
    cases = [c for c in user_code_cases(tmp_path / "cases") if c[0] == WRAP]
    assert len(cases) >= 70, len(cases)
    problems = _run_all(cases, fmus)
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


def test_the_refusals_name_the_line_and_what_the_code_did(tmp_path, monkeypatch, capsys):
    """The line each refusal says is the file's own (counted here from the source), with what was done there."""
    from tiltload.master.app.cli import main

    monkeypatch.chdir(tmp_path)
    sources = wrap_sources()
    expect = {"module: sys.exit()": "calls sys.exit()", "__init__: sys.exit('bye')": "calls sys.exit('bye')",
              "step: a file appended to": "it does I/O (open('trace.log'))",
              "step: a write swallowed by except": "it does I/O (open('w.txt'))",
              "step: a process started": "it does I/O (subprocess.Popen)",
              "__init__: a name with a dash": "self.'a-b'", "two attributes, one FMU name": "both give the FMU parameter K_0"}
    for label, needle in expect.items():
        label = next(k for k in sources if k.endswith(label))
        source = sources[label][1]
        path = tmp_path / "c.py"
        path.write_text(source)
        assert main(["wrap", "--native", str(path), "--out", str(tmp_path / "c.fmu")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and needle in err, (label, err)
        if "sys.exit" in needle or "I/O" in needle:  # the line of the statement, counted in the source
            statement = {"module: sys.exit()": "sys.exit()", "__init__: sys.exit('bye')": "sys.exit('bye')",
                         "step: a process started": "subprocess.run"}.get(label, "open(")
            line = next(n for n, text in enumerate(source.splitlines(), 1) if statement in text)
            assert f"line {line} " in err, (label, line, err)
        assert not (tmp_path / "c.fmu").exists() and not (tmp_path / "trace.log").exists() and not (tmp_path / "w.txt").exists()
    path = tmp_path / "nul.py"
    path.write_bytes(sources["a NUL byte at line 4"][1].encode())
    assert main(["wrap", str(path)]) == 2
    assert "failed at line 4: a NUL byte" in capsys.readouterr().err


def test_chdir_in_init_changes_nothing_of_tiltloads_paths(tmp_path, monkeypatch, capsys):
    """__init__ runs in the child: its os.chdir('/') leaves this process's folder, and a relative --out lands here."""
    from tiltload.master.app.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.py").write_text(_cls(init="        os.chdir('/')\n        self.k = 2.0\n"))
    assert main(["wrap", "--native", "c.py", "--out", "c.fmu"]) == 0, capsys.readouterr().err
    assert Path.cwd() == tmp_path and (tmp_path / "c.fmu").is_file()


def test_runs_and_small_cases_each_get_one_line_and_exit_2(fmus, tmp_path, monkeypatch):
    """A file where parts/ goes, a controller that is not an FMU (refused before any cluster: the census's timing says
    so too), requirement names with control characters, newlines in values, the design API at huge sample times."""
    monkeypatch.chdir(tmp_path)
    cases = [c for c in user_code_cases(tmp_path / "cases") if c[0] != WRAP]
    assert len(cases) >= 50, len(cases)
    problems = _run_all(cases, fmus)
    assert not problems, f"{len(problems)} of {len(cases)} cases:\n" + "\n".join(problems)


def test_an_error_line_shows_a_users_newline_as_an_escape(tmp_path, capsys):
    """The value as typed, its newline shown as \\n, on one line (the name's own check says what is wrong)."""
    from tiltload.master.app.cli import main

    path = tmp_path / "r.yaml"
    path.write_text('requirements:\n  - name: "swing\\n"\n    formula: plant.x < 5\n')
    assert main(["check", str(path), "--explain"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'swing\\n'" in err, err
