"""The case core (master/app/case/, docs/architecture.md): one builder of a run's system under every path, one grammar of
what varies for campaigns and searches alike, every default written once."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DEFAULTS = ROOT / "master" / "app" / "loop" / "defaults.py"


# ---- every default once ----------------------------------------------------------------------------------------------

def _defaults() -> dict[str, object]:
    """The case defaults by the names the code gives them (a field, a parameter, a spec key, an option)."""
    from tiltload.master.app.loop import defaults as d

    return {"seed": d.SEED, "scenario": d.SCENARIO, "controller": d.CONTROLLER, "max_tilt": d.MAX_TILT, "vehicle": d.VEHICLE,
            "gusts": d.GUSTS, "worker_timeout": d.WORKER_TIMEOUT, "fmus": str(d.FMU_DIR)}


def _same(node: ast.AST, value: object) -> bool:
    return isinstance(node, ast.Constant) and type(node.value) is type(value) and node.value == value


def literal_defaults(source: str, defaults: dict[str, object]) -> list[tuple[int, str]]:
    """Where source writes a case default as a literal: a parameter's or a field's default, `.get(key, default)`, an
    option's `default=` (add_argument("--max-tilt", default=30.0)) or Path("fmus")."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            a = node.args
            positional = a.posonlyargs + a.args
            pairs = list(zip(positional[len(positional) - len(a.defaults):], a.defaults))
            pairs += [(k, v) for k, v in zip(a.kwonlyargs, a.kw_defaults) if v is not None]
            found += [(v.lineno, f"{node.name}({k.arg}=...)") for k, v in pairs if k.arg in defaults and _same(v, defaults[k.arg])]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None:
            name = node.target.id
            if name in defaults and _same(node.value, defaults[name]):
                found.append((node.lineno, f"{name} = ..."))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get" and len(node.args) == 2:
            key, value = node.args
            if isinstance(key, ast.Constant) and key.value in defaults and _same(value, defaults[key.value]):
                found.append((node.lineno, f".get({key.value!r}, ...)"))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "add_argument":
            options = [a.value.lstrip("-").replace("-", "_") for a in node.args if isinstance(a, ast.Constant)
                       and isinstance(a.value, str)]
            for kw in node.keywords:
                if kw.arg == "default" and any(o in defaults and _same(kw.value, defaults[o]) for o in options):
                    found.append((kw.value.lineno, f"--{options[0]} default"))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "Path" and node.args:
            if _same(node.args[0], defaults["fmus"]):
                found.append((node.lineno, 'Path("fmus")'))
    return found


def test_the_scan_finds_each_way_of_writing_a_default():
    """The scan is no test that cannot fail: each form is found in a made-up module."""
    source = '''
from pathlib import Path
def run(seed=1, *, max_tilt=30.0): ...
class Case:
    scenario: str = "zse"
    gusts: bool = True
spec.get("controller", "mixed")
p.add_argument("--max-tilt", type=float, default=30.0)
p.add_argument("--worker-timeout", default=30.0)
FMUS = Path("fmus")
def other(seed=2, tilt=30.0, name="zse"): ...
'''
    found = literal_defaults(source, _defaults())
    assert [line for line, _ in found] == [3, 3, 5, 6, 7, 8, 9, 10], found


def test_every_default_of_a_case_is_written_once():
    defaults = _defaults()
    sources = [*sorted((ROOT / "master" / "app").rglob("*.py")), *sorted((ROOT / "tiltload").glob("*.py"))]
    found = [f"{p.relative_to(ROOT)}:{line}: {what}" for p in sources if p != DEFAULTS
             for line, what in literal_defaults(p.read_text(), defaults)]
    assert found == [], "a default written again (use master/app/loop/defaults.py)"


# ---- one grammar of what varies ---------------------------------------------------------------------------------------

CAMPAIGN = """name = "grammar"
[base]
scenario = "fsi"
trajectory = 1
stop_time = 2.0
faults = [{{name = "thrust", action = "scale", target = "plant.f_R", value = 1.0, start = 0.5, end = 1.0}}]
[vary]
seeds = [1]
[[vary.parameters]]
name = "p"
targets = [{targets}]
values = [0.25]
"""
SEARCH = """name = "grammar"
[base]
scenario = "fsi"
trajectory = 1
stop_time = 2.0
faults = [{{name = "thrust", action = "scale", target = "plant.f_R", value = 1.0, start = 0.5, end = 1.0}}]
[[requirements]]
name = "r"
formula = "always[0:1] (abs(plant.x) < 10)"
{search}
[budget]
simulations = 4
"""


@pytest.mark.parametrize("target", ["plant.m_L", "faults.0.value", "faults.0.duration", "initial.x", "gust.amplitude"])
def test_a_campaign_and_a_search_turn_a_target_into_the_same_run_parameters(tmp_path, target):
    """One grammar: the same target and value give a campaign case and a search point the same parameters."""
    from tiltload.master.app.campaign.spec import load as load_campaign
    from tiltload.master.app.falsify.space import case_parameters
    from tiltload.master.app.falsify.spec import load as load_search

    (tmp_path / "c.toml").write_text(CAMPAIGN.format(targets=f'"{target}"'))
    search = f'[[search]]\nname = "p"\ntarget = "{target}"\nrange = [0.0, 1.0]\n'
    (tmp_path / "s.toml").write_text(SEARCH.format(search=search))
    case = load_campaign(tmp_path / "c.toml").cases[0]
    point = case_parameters(load_search(tmp_path / "s.toml").base(), {"p": 0.25})
    assert case.parameters == point
    if target == "initial.x":  # the start of trajectory 1 plus the offset (the circle starts 30 cm off on each axis)
        from tiltload.master.app.loop.inputs import trajectory

        assert point["plant.x_0"] == trajectory(1).start[0] + 0.25
    if target == "faults.0.duration":
        assert point["faults.0.end"] == 0.5 + 0.25


def test_a_campaign_refuses_what_names_nothing_as_a_search_does(tmp_path):
    from tiltload.master.app.campaign.spec import load as load_campaign
    from tiltload.master.app.case.spec_file import SpecError

    for target, needle in (("gust.width", "a gust has amplitude, direction"), ("faults.3.start", "names a fault base.faults"),
                           ("wing.span", "nor a parameter of the loop's instances"), ("waypoints.0.x", "waypoints.K.* is a search's")):
        (tmp_path / "c.toml").write_text(CAMPAIGN.format(targets=f'"{target}"'))
        with pytest.raises(SpecError, match=needle):
            load_campaign(tmp_path / "c.toml")


# ---- one builder --------------------------------------------------------------------------------------------------------

@pytest.fixture
def builds(monkeypatch):
    """Every call of the one builder, as (prepared, a system file?)."""
    from tiltload.master.app.case import system

    calls = []
    original = system.build_system

    def recording(opts, *args, **kwargs):
        calls.append(kwargs.get("prepared", False))
        return original(opts, *args, **kwargs)

    monkeypatch.setattr(system, "build_system", recording)
    return calls


def test_a_run_builds_its_system_with_the_one_builder(fmus, builds, tmp_path):
    import tiltload as tl

    tl.run(scenario="fsi", stop_time=0.12, fmus=fmus, out=tmp_path, no_log=True, quiet=True)
    assert builds == [False]


def test_a_campaign_case_a_branch_and_a_search_point_build_with_the_one_builder(fmus, builds, tmp_path):
    from dataclasses import asdict

    from tiltload.master.app.batch.worker import CaseWorker
    from tiltload.master.app.campaign.run_case import run_case
    from tiltload.master.app.campaign.spec import load as load_campaign
    from tiltload.master.app.falsify.evaluate import evaluate
    from tiltload.master.app.falsify.runner import make_case
    from tiltload.master.app.falsify.spec import load as load_search

    worker = CaseWorker(keep=False)
    (tmp_path / "c.toml").write_text(CAMPAIGN.format(targets='"plant.m_L"').replace("0.25", "0.05"))
    campaign = load_campaign(tmp_path / "c.toml")
    outcome = run_case(campaign.base(), asdict(campaign.cases[0]), str(fmus), None, worker=worker)
    assert outcome["row"]["completed"], outcome
    assert builds == [True]

    search = '[[search]]\nname = "p"\ntarget = "faults.0.value"\nrange = [0.9, 1.0]\n'
    (tmp_path / "s.toml").write_text(SEARCH.format(search=search))
    base = load_search(tmp_path / "s.toml").base()
    outcome = evaluate(base, make_case(base)("r0", {"p": 0.95}), str(fmus), worker)
    assert outcome["row"]["completed"], outcome
    assert builds == [True, True]

    import tiltload as tl

    snap = tmp_path / "at.snapshot"
    tl.run(scenario="fsi", stop_time=0.6, fmus=fmus, out=tmp_path, no_log=True, quiet=True, snapshot_at=(0.36, snap))
    del builds[:]
    from tiltload.master.app.case.system import branch_system
    from tiltload.master.engine import snapshot

    system, _ = branch_system(fmus, snapshot.read(snap), None, {}, "mixed")
    assert builds == [True] and {i.name for i in system.instances} == {"plant", "sensors", "controller", "scenario"}


# ---- one record, read back ---------------------------------------------------------------------------------------------

def test_a_log_opens_as_the_result_its_run_returned(fmus, tmp_path):
    """tl.open_log reads the record every log carries: the same case, metrics, verdicts, FMUs and replay command as the
    Result tl.run returned, and the FMUs' digests are the files' own (an independent SHA-256)."""
    import hashlib

    import tiltload as tl

    ran = tl.run(scenario="fsi", stop_time=12.0, fmus=fmus, out=tmp_path, no_plots=True, quiet=True, seed=3,
                 requirements=ROOT / "docs" / "requirements" / "thesis.yaml", set={"plant.m_L": 0.06})
    opened = tl.open_log(ran.log)
    from dataclasses import replace

    def described(case):  # the case with every default filled in; where the FMUs were built is no part of it
        return replace(case.loop_options(), fmus=None)

    assert described(opened.case) == described(ran.case) and opened.record == ran.record
    import shlex

    from tiltload.master.app.cli import parser
    from tiltload.master.app.commands.run import case_of

    replayed = case_of(parser().parse_args([*shlex.split(opened.command)[1:], "--fmus", str(fmus)]))  # the record's replay
    assert described(replayed) == described(ran.case)
    assert opened.metrics == ran.metrics and opened.ticks == ran.ticks
    assert [(r.name, r.verdict, r.robustness) for r in opened.requirements] == \
           [(r.name, r.verdict, r.robustness) for r in ran.requirements] and opened.verdicts
    assert opened.fmus == ran.fmus and {f.instance for f in opened.fmus} == {"plant", "sensors", "controller", "scenario"}
    for f in opened.fmus:
        assert f.sha256 == hashlib.sha256((fmus / f.path).read_bytes()).hexdigest()
    assert opened.signals("/plant")["x"].shape == ran.signals("/plant")["x"].shape


def test_a_file_that_is_no_log_is_one_line(tmp_path):
    import tiltload as tl

    bad = tmp_path / "notes.mcap"
    bad.write_text("hello")
    with pytest.raises(tl.TiltloadError) as err:
        tl.open_log(bad)
    assert str(bad) in str(err.value) and "\n" not in str(err.value)


# ---- one set of field types under both faces -------------------------------------------------------------------------

def _tables():
    import tiltload as tl
    from tiltload.master.app.campaign.options import CAMPAIGN
    from tiltload.master.app.case.fields import CASE, RUN
    from tiltload.master.app.falsify.options import FALSIFY

    return ((CASE, tl.Case, "run"), (RUN, tl.RunOptions, "run"), (CAMPAIGN, tl.CampaignOptions, "campaign"),
            (FALSIFY, tl.FalsifyOptions, "falsify"))


def _option(command: str, flag: str):
    from tiltload.master.app.cli import parser

    sub = next(a for a in parser()._actions if a.choices and command in a.choices).choices[command]
    return next(a for a in sub._actions if flag in a.option_strings)


def test_each_option_and_its_request_field_take_one_type_from_the_core():
    """The command's option --stop-time and the API's field stop_time are checked by the one value type or set of
    choices the core declares (case/fields.py and its siblings), never by a copy."""
    from dataclasses import fields

    from tiltload.master.app.case.fields import flag_of

    checked = 0
    for table, request, command in _tables():
        names = {f.name for f in fields(request)}
        for name in [*table.types, *table.choices]:
            assert name in names, f"{request.__name__} has no field {name}"
            option = _option(command, flag_of(name))
            if name in table.types:
                assert option.type is table.types[name], flag_of(name)
            else:
                assert tuple(option.choices) == tuple(table.choices[name]), flag_of(name)
            checked += 1
    assert checked >= 30


BAD = {"seed": -1, "stop_time": 0, "max_tilt": 181, "log_every": 0, "realtime": 1e9, "max_overruns": -2, "step_timeout": 1e9,
       "workers": 0, "connect_timeout": -1, "worker_timeout": 1e9, "retries": 101, "simulations": 0, "seconds": -3,
       "neighbourhood_fraction": 0, "neighbourhood_points": 16, "vehicle": "boat", "scenario": "x", "schedule": "gauss",
       "optimizer": "annealing", "branch": "maybe", "fmi": 4, "name": "a/b"}


def test_a_refused_value_is_the_same_line_from_the_api_and_the_command(tmp_path, capsys):
    import tiltload as tl
    from tiltload.master.app.case.fields import flag_of
    from tiltload.master.app.cli import main

    spec = tmp_path / "spec.toml"  # never read: the option is refused first
    compared = set()
    for table, request, command in _tables():
        for name in [*table.types, *table.choices]:
            if name not in BAD:
                continue
            with pytest.raises(tl.TiltloadError) as err:
                request(**{name: BAD[name]})
            argv = [command, *([str(spec)] if command != "run" else []), f"{flag_of(name)}={BAD[name]}"]
            with pytest.raises(SystemExit) as stop:
                main(argv)
            assert stop.value.code == 2
            assert capsys.readouterr().err.strip().splitlines() == [err.value.cli_line], name
            compared.add(name)
    assert compared == set(BAD)
