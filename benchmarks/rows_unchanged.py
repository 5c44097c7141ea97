"""Issue 52's "results unchanged": the rows of searches and of a campaign, this tree's against another tree's, on the
same FMUs, column for column (the timing columns and the worker's address aside).

    python benchmarks/rows_unchanged.py --before /work/wt/s0 --before-python /work/venvs/s0/bin/python

What runs, in each tree's own interpreter (`--inner`): the eight specs of benchmarks/search_throughput.py (the four
shipped searches and one a kind of dimension: steady wind, plant parameters, initial offsets, a moved mission) and a
harsher twin of each (every requirement's bound at 0.3 of its value, so that runs stop early at a decided violation;
the load's mass searched up to 6 kg where it is searched, so that the feasibility check refuses), 48 evaluations each,
uniform, on 2 workers, whole budgets; and a 120-run campaign of 2 s runs with 0.05, 2.5 and 6 kg loads (some refused).
Exit 1 when a row differs (the first differences printed), 0 when every row is the same.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMING = {"wall_s", "cpu_s", "worker", "setup_s", "sim_wall_s"}
# the load's start moved along x around trajectory 1's (x = 1.7 m), as the FMU parameter plant.x_0: a target both trees
# read alike. (Until the one grammar of targets, a campaign read initial.x as an FMU instance "initial": every such run
# was refused with "unknown FMU instance 'initial'", in both trees; now it is the offset a search's initial.x is.)
OFFSETS = """[[vary.parameters]]
name = "x0"
targets = ["plant.x_0"]
values = [1.7, 1.8, 1.6, 1.9, 1.5]
"""


def campaign_text() -> str:
    """The benchmark's short-run campaign (search_throughput.CAMPAIGN) with loads the check refuses (2.5 and 6 kg) and
    the load's start moved: 120 runs."""
    from search_throughput import CAMPAIGN

    text = CAMPAIGN.format(seeds=[1, 2, 3, 4])
    assert "values = [0.05, 0.06]" in text and "[keep]" in text, "search_throughput.CAMPAIGN changed its form"
    return text.replace("values = [0.05, 0.06]", "values = [0.05, 2.5, 6.0]").replace("[keep]", OFFSETS + "[keep]")


def harsher(text: str) -> str:
    """The spec's twin: each formula's numbers after < or > at 0.3 of their value; the load's mass range to 6 kg."""
    def bound(m: re.Match) -> str:
        return f"{m.group(1)}{0.3 * float(m.group(2))!r}"

    text = re.sub(r'^(formula = ".*)$', lambda line: re.sub(r"([<>]=? *)([0-9.]+(?:e-?[0-9]+)?)", bound, line.group(1)),
                  text, flags=re.M)
    text = re.sub(r'(target = "plant.m_L"\nrange = \[)[^\]]*\]', r"\g<1>0.04, 6.0]", text)
    return re.sub(r'^name = "([^"]+)"', r'name = "\1_harsher"', text, count=1, flags=re.M)


def inner(fmus: Path, out: Path) -> None:
    """In this tree's interpreter: the searches' and the campaign's rows, as JSON lines into out."""
    import pyarrow.parquet as pq
    from search_throughput import kind_specs
    try:
        from tiltload.master.app.batch.cluster import local_cluster
    except ImportError:  # a tree from before the batch runtime had a folder of its own (5052690)
        from tiltload.master.app.campaign.cluster import local_cluster
    from tiltload.master.app.campaign.runner import run as campaign
    from tiltload.master.app.falsify.runner import falsify

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with tempfile.TemporaryDirectory(prefix="rows-unchanged-") as tmp, open(out, "w") as sink:
        tmp = Path(tmp)
        specs = kind_specs(tmp)
        for name, path in list(specs.items()):  # the shipped specs as 953560a shipped them (stop_time 8.1, which both
            if path.parent != tmp:  # trees accept; 8.0, an 8 s run deciding always[2:8] since, is refused before it)
                specs[name] = tmp / path.name
                specs[name].write_text(re.sub(r"^stop_time = 8\.0$", "stop_time = 8.1", path.read_text(), flags=re.M))
        for name, path in list(specs.items()):
            twin = tmp / f"{path.stem}_harsher.toml"
            twin.write_text(harsher(path.read_text()))
            specs[f"{name} (harsher)"] = twin
        client, cluster = local_cluster(2, scratch=tmp)
        try:
            for name, path in specs.items():
                folder = tmp / re.sub(r"\W+", "_", name)
                falsify(path, folder, fmus, optimizer="uniform", seed=3, simulations=48, client=client,
                        progress=lambda _: None, write_report=False, branch="off", stop_when_falsified=False)
                for row in pq.read_table(folder / "falsification.parquet").to_pylist():
                    sink.write(json.dumps({"what": name, **{k: v for k, v in row.items() if k not in TIMING}},
                                          sort_keys=True, default=repr) + "\n")
            spec = tmp / "rows.toml"
            spec.write_text(campaign_text())
            results, _ = campaign(spec, tmp / "campaign", fmus, progress=lambda _: None,
                                  scheduler=cluster.scheduler_address, workers=2)
            for row in pq.read_table(results).to_pylist():
                sink.write(json.dumps({"what": "campaign", **{k: v for k, v in row.items() if k not in TIMING}},
                                      sort_keys=True, default=repr) + "\n")
        finally:
            client.close()
            cluster.close()


def rows_of(python: str, tree: Path, fmus: Path, out: Path) -> list[dict]:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "benchmarks")}
    subprocess.run([python, str(Path(__file__).resolve()), "--inner", "--fmus", str(fmus), "--out", str(out)],
                   cwd=tree, env=env, check=True)
    return [json.loads(line) for line in out.read_text().splitlines()]


def key(row: dict) -> tuple:
    return (row["what"], str(row.get("run_id")))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter, allow_abbrev=False)
    ap.add_argument("--inner", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--fmus", type=Path, default=ROOT / "fmus", help="the FMUs both trees run")
    ap.add_argument("--before", type=Path, required="--inner" not in sys.argv, help="the other tree")
    ap.add_argument("--before-python", default=sys.executable, help="its interpreter (tiltload installed from it)")
    a = ap.parse_args()
    if a.inner:
        inner(a.fmus.resolve(), a.out)
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        ours = rows_of(sys.executable, ROOT, a.fmus.resolve(), Path(tmp) / "ours.jsonl")
        theirs = rows_of(a.before_python, a.before.resolve(), a.fmus.resolve(), Path(tmp) / "theirs.jsonl")
    mine, other = {key(r): r for r in ours}, {key(r): r for r in theirs}
    # a column only one tree writes (a new one, e.g. a requirement's first violation) is listed, not compared: the
    # columns both write must hold the same values
    here, there = {c for r in ours for c in r}, {c for r in theirs for c in r}
    for side, only in (("here", sorted(here - there)), ("there", sorted(there - here))):
        if only:
            print(f"columns only {side} (not compared): {', '.join(only)}")
    shared = here & there

    def common(row: dict | None) -> dict | None:
        return None if row is None else {c: v for c, v in row.items() if c in shared}

    differ = [k for k in sorted(set(mine) | set(other)) if common(mine.get(k)) != common(other.get(k))]
    searches = {r["what"] for r in ours if r["what"] != "campaign"}
    stops = sum(1 for r in ours if r.get("stopped_at") == r.get("stopped_at") and r.get("stopped_at") is not None)
    refused = sum(1 for r in ours if str(r.get("error", "")).startswith("the reference"))
    print(f"{len(ours)} rows here, {len(theirs)} there: {len(searches)} searches and a campaign of "
          f"{sum(1 for r in ours if r['what'] == 'campaign')} runs; {stops} stopped early, {refused} refused")
    for k in differ[:5]:
        a_row, b_row = mine.get(k, {}), other.get(k, {})
        cols = sorted(c for c in set(a_row) | set(b_row) if a_row.get(c) != b_row.get(c))
        print(f"differs: {k}: " + "; ".join(f"{c}: {a_row.get(c)!r} here, {b_row.get(c)!r} there" for c in cols[:4]))
    print("every row the same" if not differ else f"{len(differ)} rows differ")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
