"""Behaviour kept through a redesign: the twelve reproduction logs of this tree against another tree's, message for
message, on the same FMUs.

    python benchmarks/logs_unchanged.py --before TREE --before-python PY [--fmus DIR] [--work DIR]

Each tree runs `tiltload reproduce --fmus DIR --out WORK/<tree>` with its own interpreter (the twelve cases of ch. 5 at
their full length, one process per core, full logs); then every pair of logs is read record by record (mcap's reader):
each message's channel topic, log time, publish time and bytes must be the same, in the same order, and so must each
log's channels and metadata records other than the ones that say when and where the run was made (an FMU build's
identity, its digests and GUID, is reported apart: a tree whose FMU packages' Python sources differ rebuilds them, the
same C). Exit 1 on the first difference of each log (printed), 0 when all twelve are the same.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MOMENT = {"created", "wall", "host", "machine", "when", "started", "python", "tiltload_version", "path", "log"}  # where/when
BUILD = (".sha256", ".content", ".guid")  # an FMU build's identity: a tree whose FMU packages' sources differ rebuilds them


def reproduce(python: str, tree: Path, fmus: Path, out: Path) -> None:
    env = {**os.environ, "PYTHONPATH": ""}
    subprocess.run([python, "-m", "tiltload.master.app.cli", "reproduce", "--fmus", str(fmus), "--out", str(out)],
                   cwd=tree, env=env, check=True)


def records(path: Path):
    """(messages as (topic, log_time, publish_time, bytes)), (channel topics and encodings), metadata records."""
    from mcap.reader import make_reader

    with path.open("rb") as f:
        reader = make_reader(f)
        messages = [(ch.topic, m.log_time, m.publish_time, bytes(m.data)) for _, ch, m in reader.iter_messages(log_time_order=False)]
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        channels = sorted((c.topic, c.message_encoding) for c in summary.channels.values()) if summary else []
        metadata = [(m.name, {k: v for k, v in m.metadata.items() if k not in MOMENT}) for m in reader.iter_metadata()]
    return messages, channels, metadata


def first_difference(a: Path, b: Path) -> str | None:
    ma, ca, da = records(a)
    mb, cb, db = records(b)
    if ca != cb:
        return f"channels differ: {sorted(set(ca) ^ set(cb))[:4]}"
    if len(ma) != len(mb):
        return f"{len(ma)} messages against {len(mb)}"
    for i, (x, y) in enumerate(zip(ma, mb)):
        if x != y:
            return f"message {i} ({x[0]} at {x[1] / 1e9:.3f} s) differs"
    rebuilt = []
    for (na, ka), (nb, kb) in zip(da, db):
        keys = sorted(k for k in set(ka) | set(kb) if ka.get(k) != kb.get(k))
        rebuilt += [f"{na}.{k}" for k in keys if k.endswith(BUILD)]
        keys = [k for k in keys if not k.endswith(BUILD)]
        if na != nb or keys:
            return f"metadata {na}: {keys[:6]}"
    return f"the same (other FMU builds: {', '.join(sorted({k.rsplit('.', 1)[0] for k in rebuilt}))})" if rebuilt else None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--before", type=Path, required=True, help="the other tree")
    parser.add_argument("--before-python", required=True, help="the other tree's interpreter (tiltload installed from it)")
    parser.add_argument("--fmus", type=Path, default=ROOT / "fmus")
    parser.add_argument("--work", type=Path, default=Path("/tmp/logs_unchanged"))
    parser.add_argument("--no-run", action="store_true", help="compare the logs already in WORK")
    args = parser.parse_args()
    runs = {"after": (sys.executable, ROOT), "before": (args.before_python, args.before.resolve())}
    if not args.no_run:
        for name, (python, tree) in runs.items():
            print(f"{name}: tiltload reproduce in {tree}", flush=True)
            reproduce(python, tree, args.fmus.resolve(), args.work / name)
    logs = sorted(p.name for p in (args.work / "after").glob("*.mcap"))
    same = 0
    for name in logs:
        problem = first_difference(args.work / "after" / name, args.work / "before" / name)
        n = len(records(args.work / "after" / name)[0])
        print(f"{name}: {'the same, ' + str(n) + ' messages' if problem is None else problem}")
        same += problem is None or problem.startswith("the same")
    print(f"{same} of {len(logs)} logs the same message for message")
    return 0 if same == len(logs) == 12 else 1


if __name__ == "__main__":
    raise SystemExit(main())
