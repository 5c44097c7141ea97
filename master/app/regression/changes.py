"""What changed between a baseline and a run, said before any signal or metric: each FMU by its digest, model and
GUID, and its parameters ("controller parameter x_0 1.7 -> 1.75; plant, scenario and sensors unchanged"); a wrapped
class's changed lines from the source its FMU carries ("controller class line 27 `k = 10.0` -> `k = 10.1`").

The records are engine.log.provenance's (a log's "fmus" metadata, copied into every baseline). A baseline or log without one
(written before tiltload kept them) says what differs between the two cases' controller --set values instead.
"""

from __future__ import annotations

from pathlib import Path

from ...engine.log.provenance import instance_names, parameters

SHOWN = 6  # parameters named one by one; the rest counted


def load_fmus(path: Path) -> dict[str, str] | None:
    """The fmus record of a log (.mcap), a metrics baseline (.json) or a signal baseline (.parquet); None without one."""
    path = Path(path)
    if path.suffix == ".json":
        from ...engine.user_files import read_json

        data = read_json(path)
        record = data.get("fmus") if isinstance(data, dict) else None
    elif path.suffix == ".parquet":
        from .signal_baseline import read_header

        record = read_header(path).get("fmus")
    else:
        from ...engine.log.reader import read_metadata

        record = read_metadata(path).get("fmus")
    return {str(k): str(v) for k, v in record.items()} if isinstance(record, dict) else None


def _fmu_change(name: str, base: dict[str, str], run: dict[str, str]) -> str | None:
    bm, bd, bf = (base.get(f"{name}.{k}", "") for k in ("model", "sha256", "fmu"))
    rm, rd, rf = (run.get(f"{name}.{k}", "") for k in ("model", "sha256", "fmu"))
    bc, rc = base.get(f"{name}.content"), run.get(f"{name}.content")
    if bd == rd or (bc and bc == rc):  # the same file, or the same content but for its build stamps (GUID, date)
        return None
    if bm != rm:
        return f"{name} FMU replaced: {bm} ({bf}) -> {rm} ({rf})"
    files = bf if bf == rf else f"{bf} -> {rf}"
    return f"{name} FMU's content changed ({files}, sha256 {bd[:12]} -> {rd[:12]})"


def _source_change(name: str, base: dict[str, str], run: dict[str, str]) -> str | None:
    """A wrapped class's changed lines, in the user's words: "controller class line 27 `Q *= 10.0` -> `Q *= 10.1`"."""
    import difflib

    old, new = base.get(f"{name}.source"), run.get(f"{name}.source")
    if not old or not new or old == new:
        return None
    a, b = old.splitlines(), new.splitlines()
    said = []
    for tag, i1, i2, j1, j2 in difflib.SequenceMatcher(None, a, b, autojunk=False).get_opcodes():
        if tag == "equal":
            continue
        was = " / ".join(f"`{line.strip()}`" for line in a[i1:i2]) or "nothing"
        now = " / ".join(f"`{line.strip()}`" for line in b[j1:j2]) or "nothing"
        said.append(f"line {j1 + 1} {was} -> {now}" if j2 > j1 else f"line {i1 + 1} {was} removed")
    shown = "; ".join(said[:3]) + (f"; {len(said) - 3} more changes" if len(said) > 3 else "")
    return f"{name} class {shown}"


def _parameter_changes(name: str, base: dict[str, str], run: dict[str, str]) -> list[str]:
    pb, pr = parameters(base, name), parameters(run, name)
    changed = [(k, pb.get(k, "unset"), pr.get(k, "unset")) for k in {**pb, **pr} if pb.get(k) != pr.get(k)]
    out = [f"{name} parameter {k} {b} -> {r}" for k, b, r in changed[:SHOWN]]
    if len(changed) > SHOWN:
        out.append(f"{len(changed) - SHOWN} more {name} parameters")
    return out


def _and(names: list[str]) -> str:
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} and {names[-1]}"


def what_changed(base: dict[str, str] | None, run: dict[str, str] | None) -> list[str]:
    """What differs between the baseline's FMUs and the run's, each an item, the unchanged ones last; empty when the two
    ran the same FMUs with the same parameters, or when either records none."""
    if base is None or run is None:
        return []
    names = list(dict.fromkeys([*instance_names(base), *instance_names(run)]))
    parameters, contents, unchanged = [], [], []
    for name in names:
        if f"{name}.fmu" not in run:
            contents.append(f"{name} removed")
            continue
        if f"{name}.fmu" not in base:
            contents.append(f"{name} added ({run.get(f'{name}.model', '?')})")
            continue
        mine = _parameter_changes(name, base, run)
        source = _source_change(name, base, run)
        content = _fmu_change(name, base, run)
        parameters += mine + ([source] if source else [])
        contents += [content] if content else []
        if not mine and not content:
            unchanged.append(name)
    # every parameter first, whichever instance it is of: a changed gain is what a user looks for; the FMUs' contents
    # change with any rebuild (a new tiltload rebuilds every FMU), so they come after
    items = parameters + contents
    if not items:
        return []
    if unchanged:
        items.append(f"{_and(unchanged)} unchanged")
    return items


def settings_changed(base_case: dict | None, run_case: dict | None, instance: str = "controller") -> list[str]:
    """For records without FMUs: the instance's --set values that differ ("controller --set x_0=1.75 vs none")."""
    from ..case.record import instance_settings

    if base_case is None or run_case is None:
        return []
    b, r = instance_settings(base_case, instance), instance_settings(run_case, instance)
    return [] if b == r else [f"{instance} --set {r or 'none'} vs {b or 'none'}"]


def between(base_fmus: dict | None, run_fmus: dict | None, base_case: dict | None, run_case: dict | None) -> list[str]:
    """What changed from the baseline to the run: by the FMUs' records when both have one, else by the controller's
    --set values."""
    if base_fmus is not None and run_fmus is not None:
        return what_changed(base_fmus, run_fmus)
    return settings_changed(base_case, run_case)


def summary(items: list[str]) -> str:
    """The one line a report starts with."""
    return "what changed: " + "; ".join(items)
