"""MIL / SIL / PIL of the thesis's controller on the twelve reproduction cases, back to back (docs/mil_sil_pil.md).

The reference is SIL, the controller FMU's C in this process. Each case is run three more times with the controller
as the candidate: MIL (its numpy reference implementation in a Python process), PIL (the same FMU's aarch64 binary on
tl_serve under qemu-aarch64) and a deliberately broken MIL (the gain's entry K[0, 2], right thrust on the height
error, 1 % off). Every candidate's signals are checked in the tubes of TOLERANCES; the table gives per case the
largest deviation per signal group, the verdict, the PIL controller's round trip per tick, and where the broken
candidate first leaves its tube.

    python benchmarks/mil_sil_pil.py                      # the twelve cases, their full trajectories (long: ~30 min)
    python benchmarks/mil_sil_pil.py --stop-time 3 --cases lkf_traj1_dlqr,zse_traj2_mixed
    python benchmarks/mil_sil_pil.py --write-docs         # the table into docs/mil_sil_pil.md
"""

from __future__ import annotations

import argparse
import math
import re
import time
from pathlib import Path

import tiltload as tl
from tiltload.master.app.regression.back_to_back import reproduction_cases

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "mil_sil_pil.md"
GROUPS = {"position": ("plant.x", "plant.y", "plant.z"), "yaw": ("plant.psi",), "thrusts": ("controller.f_R", "controller.f_L"),
          "torques": ("controller.tau_R", "controller.tau_L")}
# Per signal group: what "the same controller" may differ by. Positions and yaw in m and rad, thrusts in N, torques
# in N.m: a micrometre, a microradian, a micronewton (and 1e-6 relative). No time tolerance: the three run on one tick.
TOLERANCES = {"default": {"abs": 1e-6, "rel": 1e-6}}
BROKEN_GAIN = (0, 2, 1.01)  # K[0, 2] (f_R on the z error) x 1.01


def _groups(deviation: dict[str, float]) -> dict[str, float]:
    return {g: max(deviation[s] for s in names) for g, names in GROUPS.items()}


def _fmt(x: float) -> str:
    return "0" if x == 0 else "inf" if math.isinf(x) else f"{x:.1e}"


def run(stop: float | None, cases: list[str] | None, out: Path, echo=print) -> list[dict]:
    chosen = [c for c in reproduction_cases() if not cases or c.name in cases]
    sil = tl.B2BSide(stage="sil")
    candidates = {"mil": tl.B2BSide(stage="mil"), "pil": tl.B2BSide(stage="pil"),
                  "broken": tl.B2BSide(stage="mil", gain=BROKEN_GAIN)}
    results = {}
    for key, side in candidates.items():
        started = time.perf_counter()
        results[key] = tl.b2b(chosen, reference=sil, candidate=side, tolerances=TOLERANCES, stop_time=stop, out=out / key,
                              progress=lambda line, k=key: echo(f"{k}: {line.strip()}"))
        echo(f"{key}: {time.perf_counter() - started:.0f} s")
    rows = []
    for i, case in enumerate(chosen):
        mil, pil, broken = (results[k].results[i] for k in ("mil", "pil", "broken"))
        worst = broken.worst()
        rows.append({"case": case.name, "mil": _groups(mil.deviation), "mil_ok": mil.ok, "pil": _groups(pil.deviation),
                     "pil_ok": pil.ok, "pil_us": None if pil.per_tick[1] is None else 1e6 * pil.per_tick[1],
                     "mil_us": None if mil.per_tick[1] is None else 1e6 * mil.per_tick[1],
                     "broken_ok": broken.ok, "broken_signal": worst.signal if worst else "-",
                     "broken_first": worst.first_outside if worst else None,
                     "broken_out": sum(not r.passed for r in broken.rows), "broken_dev": _groups(broken.deviation)})
    return rows


def table(rows: list[dict], stop: float | None) -> str:
    head = ("| case | MIL vs SIL: position / yaw / thrusts / torques | verdict | PIL vs SIL: position / yaw / thrusts / torques "
            "| verdict | PIL µs/tick | MIL µs/tick | K[0,2] +1 % (MIL) | signals out | first out | at (s) |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        mil = " / ".join(_fmt(r["mil"][g]) for g in GROUPS)
        pil = " / ".join(_fmt(r["pil"][g]) for g in GROUPS)
        first = "-" if r["broken_first"] is None else f"{r['broken_first']:.3f}"
        lines.append(f"| {r['case']} | {mil} | {'pass' if r['mil_ok'] else 'FAIL'} | {pil} | {'pass' if r['pil_ok'] else 'FAIL'} "
                     f"| {r['pil_us']:.0f} | {r['mil_us']:.0f} | {'pass' if r['broken_ok'] else 'FAIL'} | {r['broken_out']}/8 "
                     f"| {r['broken_signal']} | {first} |")
    span = "each case's full trajectory" if stop is None else f"{stop:g} s of each case"
    return "\n".join(lines) + f"\n\n({span}; tolerance abs 1e-6, rel 1e-6 on every signal, no time tolerance.)"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("--stop-time", type=float, default=None)
    p.add_argument("--cases", default=None, help="comma-separated case names (default: the twelve)")
    p.add_argument("--out", type=Path, default=ROOT / "runs" / "mil_sil_pil")
    p.add_argument("--write-docs", action="store_true", help=f"write the table into {DOC.relative_to(ROOT)}")
    args = p.parse_args()
    rows = run(args.stop_time, args.cases.split(",") if args.cases else None, args.out)
    text = table(rows, args.stop_time)
    print(text)
    if args.write_docs:
        doc = DOC.read_text()
        doc = re.sub(r"<!-- table -->.*<!-- /table -->", lambda _: f"<!-- table -->\n{text}\n<!-- /table -->", doc, flags=re.S)
        DOC.write_text(doc)


if __name__ == "__main__":
    main()
