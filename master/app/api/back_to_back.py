"""tiltload.b2b: a case list run with a reference and a candidate, compared signal by signal in tolerance tubes, as
`tiltload b2b` does (docs/back_to_back.md; the controller's stages MIL, SIL and PIL: docs/mil_sil_pil.md)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, fields
from pathlib import Path

from ..regression.back_to_back import BackToBack, Case, Side
from .errors import TiltloadError, as_tiltload_errors

B2BSide, B2BCase = Side, Case  # the public names (tiltload.B2BSide, tiltload.B2BCase)
__all__ = ["B2BCase", "B2BSide", "BackToBack", "b2b", "case_list"]


def _side(value: Side | Mapping | None, role: str) -> Side:
    """A side given as a B2BSide or a mapping of its fields, checked."""
    if value is None:
        return Side()
    if isinstance(value, Side):
        return value
    if not isinstance(value, Mapping):
        raise TypeError(f"{role} must be a tiltload.B2BSide or a mapping of its fields, got {type(value).__name__}")
    known = {f.name for f in fields(Side)}
    unknown = sorted(set(value) - known)
    if unknown:
        raise TiltloadError(f"{role}: unknown field {unknown[0]!r} (a side has {', '.join(sorted(known))})")
    given = dict(value)
    if isinstance(given.get("fmus"), str) and given["fmus"]:
        given["fmus"] = Path(given["fmus"])
    if isinstance(given.get("settings"), Mapping):
        given["settings"] = tuple(given["settings"].items())
    elif isinstance(given.get("settings"), list):
        given["settings"] = tuple(tuple(p) if isinstance(p, (list, tuple)) else p for p in given["settings"])
    if isinstance(given.get("gain"), list):
        given["gain"] = tuple(given["gain"])
    return Side(**given)  # its values checked with the command's (regression.back_to_back.check_side)


def _wrapped(side: Side, role: str, echo) -> Side:
    """A side whose controller is a class's .py file, with that class's controller FMU instead: wrapped as `run
    --controller my_controller.py` wraps it (natively where it traces, cached by its source), the route said in one line."""
    if not (isinstance(side.controller, str) and side.controller.endswith(".py")):
        return side
    from dataclasses import replace

    from ..wrap.class_fmu import controller_fmu_of_file, wrapped_line
    from ..wrap.wrap import WrapError

    try:
        fmu = controller_fmu_of_file(Path(side.controller), field=f"the {role}'s controller")
    except WrapError as err:
        raise TiltloadError(f"the {role}'s controller: {err}") from None
    echo(f"the {role}'s controller {wrapped_line(side.controller, fmu)}")
    return replace(side, controller=str(fmu))


def case_list(cases) -> list[Case]:
    """The cases b2b takes: 'reproduction', a case list file, or a list of B2BCase / mappings."""
    from ..regression.back_to_back import checked_cases, load_cases, reproduction_cases

    if isinstance(cases, str) and cases == "reproduction":
        return reproduction_cases()
    if isinstance(cases, (str, Path)):
        return load_cases(Path(cases))
    if not isinstance(cases, Sequence) or isinstance(cases, (bytes, str)) or not cases:
        raise TypeError(f"cases must be 'reproduction', a case list file or a non-empty list of tiltload.B2BCase, got "
                        f"{type(cases).__name__}")
    given = []
    for case in cases:
        if isinstance(case, Case):
            given.append({k: v for k, v in asdict(case).items() if v is not None})
        elif isinstance(case, Mapping):
            given.append(dict(case))
        else:
            raise TypeError(f"a case must be a tiltload.B2BCase or a mapping {{scenario, trajectory, ...}}, got {type(case).__name__}")
    return checked_cases({"cases": given}, "cases")  # the case list file's schema, whatever gives the cases


def b2b(cases: str | Path | Sequence = "reproduction", *, reference: Side | Mapping | None = None,
        candidate: Side | Mapping | None = None, signals: Sequence[str] | None = None,
        tolerances: str | Path | Mapping | None = None, abs: float | None = None, rel: float | None = None,  # noqa: A002
        lead: float | None = None, lag: float | None = None, stop_time: float | None = None, out: str | Path = "runs/b2b",
        progress=None) -> BackToBack:
    """Each case run as the reference and as the candidate, the candidate's signals in the reference's tubes.

    cases: "reproduction" (the twelve of ch. 5), a case list file, or a list of B2BCase / mappings {scenario,
    trajectory, controller, seed, stop_time}. reference, candidate: a B2BSide or a mapping of its fields (fmus, controller,
    settings, stage "sil" | "mil" | "pil", gain (i, j, factor) for mil); default: the FMUs of ./fmus in this process.
    signals: "instance.variable" (default: the plant's x, y, z, psi and the four commands); tolerances: a file or a
    mapping as compare_signals takes, abs/rel/lead/lag for every signal. progress(line): told as each case ends. The
    runs go through one execution pool (each side's execution restarted for the next case). Returns a BackToBack
    (``.ok``, ``.results`` per case: ``.rows``, ``.deviation``, ``.per_tick``; ``.table()``)."""
    from ..arguments import folder
    from ..case.fields import named
    from ..regression.back_to_back import back_to_back
    from ..regression.signal_compare import Tolerances, check_names, load_tolerances, parse_tolerances

    with as_tiltload_errors():
        if not isinstance(out, (str, Path)):
            raise TypeError(f"out must be a folder (str or pathlib.Path), got {type(out).__name__}")
        named(folder, "out", str(out))  # the command's --out type: a folder, or a path where one can be made
        if stop_time is not None:
            from ...command_line.argument_types import run_time

            named(run_time, "stop_time", stop_time)
        case_list_ = case_list(cases)
        sides = tuple(_wrapped(_side(side, role), role, progress or (lambda line: None))
                      for side, role in ((reference, "reference"), (candidate, "candidate")))
        names = check_names(list(signals), "signals") if signals else None
        if tolerances is None:
            given = Tolerances()
        elif isinstance(tolerances, (str, Path)):
            given = load_tolerances(Path(tolerances))
        elif isinstance(tolerances, Mapping):
            given = parse_tolerances(dict(tolerances), "tolerances")
        else:
            raise TypeError(f"tolerances must be a file or a mapping, got {type(tolerances).__name__}")
        if names is None and given.signals:
            names = list(given.signals)
        flags = {"abs": abs, "rel": rel, "lead": lead, "lag": lag}
        for flag, value in flags.items():
            if value is not None:
                _check_tolerance(flag, value)
        found = back_to_back(case_list_, *sides, Path(out), names, given.with_flags(flags), stop_time,
                             echo=progress or (lambda line: None))
    return Shown(**{f.name: getattr(found, f.name) for f in fields(found)})


class Shown(BackToBack):
    """b2b's verdict (a tiltload.BackToBack), shown in a notebook as a report: a test per case, each signal's tube, a
    figure of each signal outside."""

    def _repr_html_(self) -> str:
        from .rich_display import back_to_back_report, html_fragment

        return html_fragment(back_to_back_report(self))


def _check_tolerance(name: str, value) -> None:
    from ...command_line.argument_types import tolerance
    from ..case.fields import named

    named(tolerance, name, value)
