"""`tiltload compare RUN BASELINE`: a run's metrics, or its signals in tolerance tubes, against a baseline of the same case;
exit 0 same, 1 different."""

from __future__ import annotations

import argparse
from pathlib import Path

from .. import arguments


def add_parser(sub) -> None:
    cp = sub.add_parser("compare", help="compare a run's metrics with a baseline (a log or a metrics file) of the same case; "
                                        "exit 0 same, 1 different")
    cp.add_argument("run", type=Path, help="the run: its MCAP log (runs/NAME.mcap) or a metrics file (JSON)")
    cp.add_argument("baseline", type=Path,
                    help="what to compare with: another run's MCAP log or a metrics file (JSON, with per-metric tolerances)")
    cp.add_argument("--rtol", type=arguments.tolerance, default=None,
                    help="relative tolerance for every metric, in place of the baseline's own (default: the baseline "
                         "file's per-metric tolerances, else 1e-6)")
    cp.add_argument("--atol", type=arguments.tolerance, default=None,
                    help="absolute tolerance for every metric, in place of the baseline's own (default: the baseline "
                         "file's, else 1e-12)")
    cp.add_argument("--requirements", type=Path, default=None, metavar="REQS",
                    help="also judge both logs against these requirements: a verdict that changes is a difference, "
                         "robustness is compared with the tolerances")
    cp.add_argument("--any-case", action="store_true",
                    help="compare the metrics even if the two are different cases (scenario, trajectory, controller, seed, "
                         "stop time, --set, faults, wind, ...); by default that is refused with one line saying what differs")
    cp.add_argument("--record-baseline", action="store_true",
                    help="record RUN (a log) as the baseline BASELINE instead of comparing: a signal baseline (.parquet: the "
                         "signals of --signals or of --tolerances, with those tolerances) or a metrics baseline (.json, "
                         "with --rtol, --atol); what pytest --tiltload-update-baselines writes")
    sg = cp.add_argument_group("signals in tolerance tubes (docs/back_to_back.md): with a signal baseline (.parquet), "
                               "--signals or --tolerances")
    sg.add_argument("--signals", type=_names, default=None, metavar="LIST",
                    help="signals to compare, instance.variable, comma-separated (default: the tolerance file's, else "
                         "the signal baseline's)")
    sg.add_argument("--tolerances", type=Path, default=None, metavar="FILE",
                    help="tolerances per signal: TOML, YAML or JSON with a 'default' and a 'signals' table of abs, rel, "
                         "lead, lag (default: the signal baseline's own, else abs 1e-12, rel 1e-6)")
    for flag, what in (("abs", "absolute tolerance, in the signal's unit"), ("rel", "relative tolerance, of |reference|"),
                       ("lead", "time the run may be early, s"), ("lag", "time the run may be late, s")):
        sg.add_argument(f"--{flag}", type=arguments.tolerance, default=None, help=f"{what}, for every signal")
    sg.add_argument("--figures", type=arguments.folder, default=None, metavar="DIR",
                    help="a figure of each signal outside its tube into DIR")
    cp.set_defaults(func=run)


def _names(text: str) -> list[str]:
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise argparse.ArgumentTypeError("name at least one signal (instance.variable)")
    return names


def _signal_mode(args: argparse.Namespace) -> bool:
    return (args.baseline.suffix == ".parquet" or args.signals is not None or args.tolerances is not None
            or any(getattr(args, f) is not None for f in ("abs", "rel", "lead", "lag")))


def _run_signals(args: argparse.Namespace) -> int:
    from ..regression.signal_compare import compare_signal_files

    if args.requirements is not None or args.rtol is not None or args.atol is not None:
        from ..errors import UserError

        raise UserError("--requirements, --rtol and --atol compare metrics: give them without the signal options")
    result = compare_signal_files(args.run, args.baseline, args.signals, args.tolerances,
                                  {f: getattr(args, f) for f in ("abs", "rel", "lead", "lag")}, args.any_case)
    if result.changed_line():
        print(result.changed_line())
    for note in result.notes:
        print(f"note: {note}")
    print(result.table())
    if args.figures is not None and not result.ok:
        from ..regression.tube_plot import tube_figures
        from ..views.plot import case_title

        for path in tube_figures(result.rows, args.figures, args.run.stem, case_title(result.case)):
            print(f"figure: {path}")
    print("same within tolerance" if result.ok else "DIFFERENT: at least one signal leaves its tolerance tube")
    return 0 if result.ok else 1


def _record(args: argparse.Namespace) -> int:
    """RUN recorded as BASELINE, by the functions the pytest plugin records with (tl.save_signal_baseline,
    tl.save_baseline)."""
    from ..errors import UserError

    if args.requirements is not None or args.figures is not None or args.any_case:
        raise UserError("--record-baseline records the run: --requirements, --figures and --any-case belong to comparing")
    if args.run.suffix != ".mcap":
        raise UserError(f"{args.run}: --record-baseline records a run's log (.mcap)")
    if args.baseline.suffix == ".parquet":
        from ..api.signal_comparing import save_signal_baseline
        from ..regression.signal_compare import Tolerances, check_names, load_tolerances

        if args.rtol is not None or args.atol is not None:
            raise UserError("--rtol and --atol are the metrics' tolerances: a signal baseline takes --abs, --rel, --lead, --lag")
        given = load_tolerances(args.tolerances) if args.tolerances is not None else Tolerances()
        signals = check_names(args.signals, "--signals") if args.signals else list(given.signals)
        if not signals:
            raise UserError("name the signals to record (--signals plant.x,plant.z, or a tolerance file's signals)")
        tolerances = given.with_flags({f: getattr(args, f) for f in ("abs", "rel", "lead", "lag")})
        path = save_signal_baseline(args.run, args.baseline, signals, tolerances=tolerances.to_header())
        print(f"recorded {path}: {len(signals)} signals of {args.run} ({', '.join(signals[:6])}{', ...' if len(signals) > 6 else ''})")
        return 0
    if args.baseline.suffix == ".json":
        from ..api.comparing import save_baseline

        if _signal_mode(args):
            raise UserError("a metrics baseline (.json) records the metrics: the signal options need a .parquet baseline")
        path = save_baseline(args.run, args.baseline, **{k: v for k, v in (("rtol", args.rtol), ("atol", args.atol)) if v is not None})
        print(f"recorded {path}: the metrics of {args.run}")
        return 0
    raise UserError(f"{args.baseline}: a baseline is a signal baseline (.parquet) or a metrics baseline (.json)")


def run(args: argparse.Namespace) -> int:
    from ..regression.compare import compare_files

    if args.record_baseline:
        return _record(args)

    if _signal_mode(args):
        return _run_signals(args)
    result = compare_files(args.run, args.baseline, args.rtol, args.atol, args.any_case)
    if result.changed_line():
        print(result.changed_line())
    for note in result.notes:
        print(f"note: {note}")
    print(result.table())
    ok = result.ok
    if args.requirements is not None:
        from ...engine.requirement.check import check_log
        from ...engine.requirement.files import load
        from ..errors import UserError
        from ..regression import compare as cmp

        if args.baseline.suffix == ".json" or args.run.suffix == ".json":
            raise UserError("--requirements compares two logs' verdicts: give the baseline as an MCAP log")
        reqs = load(args.requirements)
        rtol = args.rtol if args.rtol is not None else cmp.DEFAULT_RTOL
        atol = args.atol if args.atol is not None else cmp.DEFAULT_ATOL
        same, vrows = cmp.compare_verdicts(check_log(args.run, reqs, missing="inconclusive"),
                                           check_log(args.baseline, reqs, missing="inconclusive"), rtol, atol)
        print(cmp.format_verdict_rows(vrows))
        ok &= same
    print("same within tolerance" if ok else "DIFFERENT: at least one metric or verdict is out of tolerance")
    return 0 if ok else 1
