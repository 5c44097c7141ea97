"""The sensor FMU's variables, declared once from the suite's groups, and the C table of the groups.

Layout: the true state (inputs), the exact-state channel, each group's held samples, periods,
noise bounds, the tick and the rod length (Reals); the seed (Integer); each group's
distribution (String); each group's `new` flag (Boolean).
"""

from __future__ import annotations

from ..native_fmu.variables import FmuDefinition, Variable
from ..plant_fmu.interface import STATES
from .suite import GROUPS, ZSE_NAMES

DESCRIPTION = ("Sensor suite of Rego (UFMG 2016): exact state, q with Gaussian noise (Sec. 5.3), GPS, barometer, "
               "IMU, camera and servo encoders with their periods and noise (Table 5.8)")
STATE_NAMES = tuple(s[0] for s in STATES)
STATE_UNITS = tuple(s[1] for s in STATES)
TICK = 0.012


def channel_names(group) -> list[str]:
    if group.source == "q":
        return [f"lkf_{STATE_NAMES[i]}" for i in group.indices]
    return [f"meas_{ZSE_NAMES[i]}" for i in group.indices]


def channel_units(group) -> list[str]:
    return [STATE_UNITS[i] for i in group.indices] if group.source == "q" else [group.unit] * len(group.indices)


def bound_names(group) -> list[str]:
    if len(group.bounds) == 1:
        return [f"{group.name}_bound"]
    return [f"{group.name}_bound_{STATE_NAMES[i] if group.source == 'q' else ZSE_NAMES[i]}" for i in group.indices]


def definition(trim_x, rod_length: float, version: str) -> FmuDefinition:
    v = [Variable(n, "Real", "input", float(trim_x[i]), f"true state {n} (from the plant)", STATE_UNITS[i])
         for i, n in enumerate(STATE_NAMES)]
    v += [Variable(f"exact_{n}", "Real", "output", 0.0, f"{n}: exact state channel", STATE_UNITS[i])
          for i, n in enumerate(STATE_NAMES)]
    for g in GROUPS:
        v += [Variable(n, "Real", "output", 0.0, f"{n}: {g.name} sample (held)", u, discrete=True)
              for n, u in zip(channel_names(g), channel_units(g))]
    v += [Variable(f"{g.name}_period", "Real", "parameter", g.period, f"{g.name} sampling period", "s") for g in GROUPS]
    for g in GROUPS:
        units = channel_units(g)
        v += [Variable(n, "Real", "parameter", b, f"{g.name} noise bound (3 sigma if gaussian, half-width if uniform)", units[i])
              for i, (n, b) in enumerate(zip(bound_names(g), g.bounds))]
    v.append(Variable("step", "Real", "parameter", TICK, "tick: the communication step the suite expects", "s"))
    v.append(Variable("l", "Real", "parameter", rod_length, "rod length, as in the plant", "m"))
    v.append(Variable("seed", "Integer", "parameter", 1, "seed of every noise stream (0 .. 2147483647)"))
    v += [Variable(f"{g.name}_pdf", "String", "parameter", g.pdf, f"{g.name} noise distribution: gaussian or uniform")
          for g in GROUPS]
    v += [Variable(f"{g.name}_new", "Boolean", "output", False, f"{g.name} took a new sample this step") for g in GROUPS]
    return FmuDefinition("TiltloadSensors", DESCRIPTION, v, "sensor_model.h", (0.0, 1.2, TICK), variable_step=False,
                         version=version)


def group_table(definition: FmuDefinition, params, l_index: int) -> str:
    """sensor_groups.h: each group's channels and variables by value reference, and the model's parameters."""
    vr = definition.vr
    rows = []
    for g in GROUPS:
        idx = ", ".join(map(str, g.indices))
        rows.append(f'  {{"{g.name}", {int(g.source == "pi")}, {len(g.indices)}, {{{idx}}}, {vr(channel_names(g)[0])}, '
                    f'{vr(f"{g.name}_period")}, {vr(bound_names(g)[0])}, {len(g.bounds)}, {vr(f"{g.name}_pdf")}, '
                    f'{vr(f"{g.name}_new")}}}')
    p = ", ".join(repr(float(x)) for x in params)
    return "\n".join([
        "/* Generated from tiltload.sensor_fmu.suite.GROUPS: do not edit. */",
        "#ifndef SENSOR_GROUPS_H", "#define SENSOR_GROUPS_H", "",
        f"#define TL_N_GROUPS {len(GROUPS)}", f"#define TL_N_PARAMS {len(params)}", f"#define TL_L_INDEX {l_index}", "",
        "typedef struct {",
        "  const char* name;",
        "  int from_pi;   /* samples pi(x) (4.22), else q */",
        "  int n;         /* channels */",
        "  int index[16]; /* entries of pi(x) or q */",
        "  int out;       /* value reference of the first held sample (the rest follow) */",
        "  int period;    /* value reference of the period parameter */",
        "  int bound;     /* value reference of the first bound */",
        "  int n_bounds;  /* 1: one bound for all channels, else one each */",
        "  int pdf;       /* String value reference of the distribution */",
        "  int flag;      /* Boolean value reference of the new-sample flag */",
        "} TlSensorGroup;", "",
        "static const TlSensorGroup tl_sensor_groups[TL_N_GROUPS] = {", ",\n".join(rows), "};", "",
        "/* Table 5.1 parameters pi(x) is evaluated with; the rod length comes from the l parameter. */",
        f"static const double tl_sensor_p0[TL_N_PARAMS] = {{{p}}};", "", "#endif", ""])
