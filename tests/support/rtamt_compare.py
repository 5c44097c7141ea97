"""rtamt as a second oracle of the STL monitor: random formulas (depth >= 3, every operator) on random traces, evaluated
by rtamt's discrete-time offline monitor and by tiltload's, sample by sample.

rtamt is not a test dependency: it pins antlr4-python3-runtime 4.7 (a downgrade of what else may be installed) and does
not install on Python 3.13 (its issues #179, #201), so it runs in an interpreter of its own (`--rtamt-python`) and this
script compares. Run it with the project's Python:

    python tests/support/rtamt_compare.py --rtamt-python /work/venvs/oracles/bin/python [--cases 300]

It prints the number of formulas and samples compared and every disagreement; exit 1 on a disagreement.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import random
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tiltload.master.engine.requirement.stl import Evaluator, unparse  # noqa: E402
from tiltload.master.engine.requirement.stl import syntax as S  # noqa: E402

from support.stl_oracle import every_operator, rand_formula, rand_trace  # noqa: E402

# run by the rtamt interpreter: reads the cases on stdin, writes [[rho per sample] per case] on stdout
RTAMT_SIDE = r"""
import json, sys, logging
logging.disable(logging.WARNING)
import rtamt
out = []
for case in json.load(sys.stdin):
    spec = rtamt.StlDiscreteTimeSpecification()
    for name in case["signals"]:
        spec.declare_var(name, "float")
    spec.declare_var("out", "float")
    spec.spec = "out = " + case["formula"]
    spec.set_sampling_period(1, "s", 0.1)
    try:
        spec.parse()
        data = {"time": list(range(len(case["time"]))), **case["signals"]}
        out.append([r for _, r in spec.evaluate(data)])
    except Exception as err:
        out.append(f"{type(err).__name__}: {err}")
print(json.dumps(out))
"""


def rtamt_form(node):
    """The same tree within what rtamt takes: whole-second bounds, no [a:inf] with a > 0, a minus only before a number
    (-(e) becomes (0 - e))."""
    if isinstance(node, S.Arith):
        args = tuple(rtamt_form(a) for a in node.args)
        return S.Arith("-", (S.Const(0.0), args[0])) if node.op == "neg" else S.Arith(node.op, args)
    if isinstance(node, S.Compare):
        return S.Compare(node.op, rtamt_form(node.left), rtamt_form(node.right))
    if isinstance(node, (S.Always, S.Eventually, S.Until)):
        a, b = float(math.floor(node.a)), node.b if math.isinf(node.b) else float(math.floor(node.b))
        if math.isinf(b):
            a = 0.0
        kids = [rtamt_form(c) for c in S.children(node)]
        return dataclasses.replace(node, a=a, b=b, **dict(zip(("left", "right") if isinstance(node, S.Until) else ("arg",), kids)))
    if isinstance(node, (S.Not, S.And, S.Or, S.Implies)):
        kids = [rtamt_form(c) for c in S.children(node)]
        return dataclasses.replace(node, **dict(zip(("arg",) if isinstance(node, S.Not) else ("left", "right"), kids)))
    return node


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rtamt-python", required=True)
    ap.add_argument("--cases", type=int, default=300)
    args = ap.parse_args()
    cases, ours = [], []
    for seed in range(args.cases):
        rng = random.Random(seed)
        trace = rand_trace(rng, rng.randint(2, 30), 1.0)
        f = rtamt_form(every_operator(rng, 1.0) if seed % 2 == 0 else rand_formula(rng, 3, 1.0))
        cases.append({"formula": unparse(f).replace("a.x", "a_x").replace("a.y", "a_y").replace("b.z", "b_z"),
                      "time": trace.times.tolist(), "signals": {k.replace(".", "_"): v.tolist() for k, v in trace.signals.items()}})
        ours.append(Evaluator(trace)(f))
    done = subprocess.run([args.rtamt_python, "-c", RTAMT_SIDE], input=json.dumps(cases), capture_output=True, text=True)
    if done.returncode:
        print(done.stderr[-2000:])
        return 2
    theirs = json.loads(done.stdout.strip().splitlines()[-1])
    agree, samples, bad, refused = 0, 0, [], []
    for case, mine, rt in zip(cases, ours, theirs):
        if isinstance(rt, str):
            refused.append((case["formula"], rt))
            continue
        rt = np.array(rt, dtype=float)
        close = (mine == rt) | np.isclose(mine, rt, rtol=0, atol=1e-12) | (np.isnan(mine) & np.isnan(rt))
        samples += len(mine)
        if close.all():
            agree += 1
        else:
            bad.append((case["formula"], int(np.flatnonzero(~close)[0]), mine.tolist(), rt.tolist()))
    print(f"rtamt vs tiltload: {agree} of {len(cases) - len(refused)} formulas agree at every sample to 1e-12 "
          f"({samples} samples); rtamt refused {len(refused)}")
    for formula, why in refused[:5]:
        print(f"  refused: {why[:160]}  ({formula[:120]})")
    for formula, at, mine, rt in bad[:10]:
        print(f"  DISAGREE at sample {at}: {formula}\n    tiltload {mine}\n    rtamt    {rt}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
