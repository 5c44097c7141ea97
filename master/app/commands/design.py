"""`tiltload design`: a controller of the thesis (ch. 3) synthesized and saved as an artifact."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .. import arguments
from ..loop.defaults import VEHICLE
from ..loop.thesis import LOOPS


def add_parser(sub) -> None:
    d = sub.add_parser("design", help="design a controller of the thesis (ch. 3) and save it as an artifact")
    d.add_argument("--controller", default=None,
                   help="dlqr, hinf or mixed (default: the one tiltload run flies, mixed for the load, dlqr for the UAV alone)")
    d.add_argument("--vehicle", choices=tuple(LOOPS), default=VEHICLE, help="load (default) or uav: the UAV alone (dlqr only)")
    d.add_argument("--Tc", type=arguments.time_span(1.0, "period"), default=0.012,
                   help="controller period in s (default 0.012; at most 1)")
    d.add_argument("--out", type=arguments.folder, default=Path("designs"), help="output folder (default: designs)")
    d.add_argument("--fresh", action="store_true", help="synthesize again even if an identical design is cached")
    d.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ....controller_fmu.design import artifact
    from ....controller_fmu.design.synthesize import design
    from ..loop.thesis import LOOPS

    kind = args.controller or LOOPS[args.vehicle].default_controller  # one default with `tiltload run`
    d = design(kind, args.Tc, use_cache=not args.fresh, progress=lambda m: print(m, file=sys.stderr),
               vehicle=args.vehicle)
    r = d.report
    if "gamma_bound" in r and r.get("hinf_norm") is None:  # a shipped design is checked without measuring its norms
        from ....controller_fmu.design.lmi_check import measured_norms

        r["hinf_norm"], r["h2_norm"] = measured_norms(d, d.omega_chi, d.omega_u, d.K)
    path = artifact.save(d, args.out / f"{'uav_' if args.vehicle == 'uav' else ''}{d.kind}.json")
    print(f"{d.kind}: ||K||_2 = {r['gain_norm']:.4g}, closed-loop spectral radius = {r['spectral_radius']:.6f} "
          f"(slowest continuous-time decay {np.log(r['spectral_radius']) / d.Tc:.3f} /s); {_origin(d)}")
    if "riccati_residual" in r:
        print(f"  Riccati residual {r['riccati_residual']:.1e}")
    else:
        h2 = f", H2 bound {r['h2_bound']:.4g} (measured {r['h2_norm']:.4g})" if r["h2_bound"] else ""
        print(f"  H-infinity bound {r['gamma_bound']:.4g} (measured {r['hinf_norm']:.4g}){h2}; "
              f"poles in Re > {r['regions']['eps']} and |z| < {r['regions']['varpi']}; solver {r['solver_status']}")
    print(f"saved {path}")
    return 0


def _origin(d) -> str:
    """Where the design comes from, so a cached synthesis time is never shown as if it had just run."""
    took = d.report.get("seconds")
    took = f"{took:.1f} s" if isinstance(took, (int, float)) else "an unrecorded time"
    if d.origin == "synthesized":
        return f"synthesized now in {took}"
    if d.origin == "shipped":
        machine = (d.report.get("synthesis_machine") or "an unrecorded machine").split(";")[0]
        return (f"shipped with tiltload, its LMIs checked here in {d.report['check_seconds'] * 1e3:.0f} ms "
                f"(synthesized in {took} on {machine}; --fresh to synthesize)")
    return f"from the cache (synthesized earlier in {took}; --fresh to synthesize again)"
