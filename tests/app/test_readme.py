"""The README as a new user meets it: its FMPy commands work as written and show what it says, its counts are
true, its timings come from the benchmark, and it says how to get the system library a skipped test needs."""

from __future__ import annotations

import csv
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from support import DATA, ROOT
from support.system_libraries import LIBRARIES, needs_library

README = (ROOT / "README.md").read_text()
MARKER = re.compile(r"<!-- timing:(\w+) -->(.*?)<!-- /timing -->", re.S)
TYPED_TIMING = re.compile(r"(about|~|≈)\s*\d+(\.\d+)?\s*(s|min|minutes|seconds)\b")


def readme_commands(program: str) -> list[str]:
    """The lines of the README's bash blocks that run program, without their trailing comment."""
    blocks = re.findall(r"```bash\n(.*?)```", README, re.S)
    lines = [line.split("  #")[0].strip() for block in blocks for line in block.splitlines()]
    return [line for line in lines if line.startswith(program + " ")]


@pytest.fixture(scope="module")
def ran(fmus, tmp_path_factory) -> dict[str, subprocess.CompletedProcess]:
    """Every `fmpy ...` line of the README, run as written from a folder whose fmus/ holds the built FMUs."""
    where = tmp_path_factory.mktemp("readme")
    (where / "fmus").symlink_to(fmus)
    fmpy = f"{sys.executable} -m fmpy.cli"
    out = {}
    for line in readme_commands("fmpy"):
        out[line] = subprocess.run(["bash", "-c", fmpy + line[len("fmpy"):]], cwd=where, capture_output=True, text=True,
                                   timeout=300)
    out["cwd"] = where
    return out


@pytest.mark.slow
def test_every_fmpy_command_of_the_readme_works_as_written(ran):
    commands = [c for c in ran if c != "cwd"]
    assert len(commands) >= 4
    for command in commands:
        assert ran[command].returncode == 0, (command, ran[command].stderr[-500:])


def test_the_controller_fed_the_trim_shows_the_trim_inputs(ran):
    """The design brief's trim: f_R 9.987 N, f_L 10.022 N, no servo torque."""
    command = next(c for c in ran if "TiltloadController" in c)
    last = ran[command].stdout.strip().splitlines()[-1].split(",")
    f_R, f_L, tau_R, tau_L = map(float, last[1:])
    assert f_R == pytest.approx(9.987, abs=5e-4) and f_L == pytest.approx(10.022, abs=5e-4)
    assert abs(tau_R) < 1e-9 and abs(tau_L) < 1e-9


def test_the_plant_hovers_at_the_trim_for_two_seconds(ran):
    rows = list(csv.DictReader(open(ran["cwd"] / "plant.csv")))
    assert float(rows[-1]["time"]) == pytest.approx(2.0)
    assert abs(float(rows[-1]["x"]) - float(rows[0]["x"])) < 1e-9  # the drift docs/plant.md gives is 1e-13 m


def test_what_the_readme_says_fmpy_info_lists_is_what_it_lists(ran, fmus):
    from fmpy import read_model_description

    md = read_model_description(str(fmus / "TiltloadPlant.fmu"))
    io = [v for v in md.modelVariables if v.causality in ("input", "output")]
    params = [v for v in md.modelVariables if v.causality == "parameter"]
    info = ran[next(c for c in ran if c.startswith("fmpy info"))].stdout
    listed = info.split("Variables (input, output)")[1].strip().splitlines()[1:]  # after the header line
    assert len(listed) == len(io)
    assert f"the inputs and outputs only ({len(io)} of the {len(md.modelVariables)} variables): the {len(params)} parameters" in \
        " ".join(README.split())


@pytest.mark.slow
def test_the_readme_counts_the_figures_a_run_writes(tmp_path):
    from tiltload.master.app.views.plot import plot_run

    said = re.search(r"`runs/zse_traj1_mixed_seed1.mcap` with (\w+) PNG figures", " ".join(README.split()))
    words = {"five": 5, "six": 6, "seven": 7, "eight": 8}
    assert said and words[said.group(1)] == len(plot_run(DATA / "json_log_v0.mcap", tmp_path))  # a ZSE loop's log


def test_the_timings_in_the_docs_are_the_benchmark_s():
    """Figures between timing markers are what benchmarks/user_timings.py measured; none is typed elsewhere."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from user_timings import TIMINGS, figure

    measured = json.loads(TIMINGS.read_text())
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    seen = 0
    for page in pages:
        text = page.read_text()
        for key, value in MARKER.findall(text):
            assert figure(key, measured) is not None, (page.name, key)  # a figure the benchmark did not measure
            assert value == figure(key, measured), (page.name, key, value)
            seen += 1
        if page.name in ("README.md", "controller.md", "campaigns.md"):
            assert not TYPED_TIMING.search(MARKER.sub("", text)), (page.name, TYPED_TIMING.search(MARKER.sub("", text)))
    assert seen >= 10
    entries = [m for v in measured.values() for m in (v if isinstance(v, list) else [v])]  # "scale" holds one a size
    assert all(m["machine"] and m["date"] for m in entries)
    assert "about 30 s per variant" not in (ROOT / "benchmarks" / "baseline_spread.py").read_text()


def test_the_readme_says_how_to_get_the_system_library_a_skipped_test_needs():
    for soname, how in LIBRARIES.items():
        package = re.search(r"apt-get install (\S+?);", how).group(1)
        assert soname in README and f"apt-get install {package}" in README


@pytest.mark.slow
def test_a_test_needing_a_missing_system_library_skips_with_one_line_naming_it(tmp_path):
    test = tmp_path / "test_needs.py"
    test.write_text("from support.system_libraries import needs_library\n\n"
                    "@needs_library('libtiltload_nothere.so.9', 'apt-get install nothere')\n"
                    "def test_it():\n    raise AssertionError('ran without its library')\n")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", str(test),
                           "--rootdir", str(tmp_path)], capture_output=True, text=True,
                          env={"PYTHONPATH": str(ROOT / "tests"), "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 0, proc.stdout
    skipped = [line for line in proc.stdout.splitlines() if line.startswith("SKIPPED")]
    assert len(skipped) == 1 and "needs the system library libtiltload_nothere.so.9 (apt-get install nothere)" in skipped[0]
    assert needs_library("libc.so.6").args[0] is False  # a library that loads runs its tests


def test_every_tiltload_command_of_the_readme_parses_as_written(tmp_path, monkeypatch):
    """Each `tiltload ...` line of the README is accepted by the command's own parser (not run: some take minutes), in
    a folder that has the user's files it names (a parser checks that an input file is a file)."""
    import shlex

    from tiltload.master.app.cli import parser

    monkeypatch.chdir(tmp_path)
    commands = readme_commands("tiltload")
    assert len(commands) >= 15
    for command in commands:
        for part in command.split("&&"):
            argv = shlex.split(part.strip())
            for token in argv:
                if Path(token).suffix in (".fmu", ".toml", ".yaml", ".csv", ".mcap", ".py") and not Path(token).is_absolute():
                    (tmp_path / token).parent.mkdir(parents=True, exist_ok=True)
                    (tmp_path / token).touch()
            if argv and argv[0] == "tiltload":
                try:
                    parser().parse_args(argv[1:])
                except SystemExit as stop:
                    raise AssertionError(f"the README's `{part.strip()}` does not parse (exit {stop.code})") from None


def test_a_newcomer_finds_the_set_up_in_the_first_30_lines_of_a_short_readme():
    lines = README.splitlines()
    setup = [n for n, line in enumerate(lines, 1) if line.startswith('pip install -e ".[test]" && pytest')]
    assert setup and setup[0] <= 30 and any(line.startswith("pip install -e . && tiltload run") for line in lines[:30])
    assert len(lines) <= 130
