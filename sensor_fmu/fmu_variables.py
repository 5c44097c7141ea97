"""The sensor FMU's variables, declared once from the suite's groups, and the C table of the groups.

Layout: the true state (inputs), the exact-state channel, each group's held samples, periods,
noise bounds, the tick and (with the load) the rod length (Reals); the seed (Integer); each
group's distribution (String); each group's `new` flag (Boolean). One definition for both
vehicles' suites (suite.SUITES).
"""

from __future__ import annotations

from ..native_fmu.variables import Clock, FmuDefinition, Variable
from ..plant_fmu.vehicles import VEHICLES
from .suite import LOAD_SUITE, Suite

TICK = 0.012


def _state_names(suite: Suite) -> tuple[str, ...]:
    return tuple(s[0] for s in VEHICLES[suite.vehicle].states)


def _state_units(suite: Suite) -> tuple[str, ...]:
    return tuple(s[1] for s in VEHICLES[suite.vehicle].states)


def channel_names(group, suite: Suite = LOAD_SUITE) -> list[str]:
    if group.source == "q":
        return [f"lkf_{_state_names(suite)[i]}" for i in group.indices]
    return [f"meas_{suite.pi_names[i]}" for i in group.indices]


def channel_units(group, suite: Suite = LOAD_SUITE) -> list[str]:
    return [_state_units(suite)[i] for i in group.indices] if group.source == "q" else [group.unit] * len(group.indices)


def bound_names(group, suite: Suite = LOAD_SUITE) -> list[str]:
    if len(group.bounds) == 1:
        return [f"{group.name}_bound"]
    return [f"{group.name}_bound_{_state_names(suite)[i] if group.source == 'q' else suite.pi_names[i]}" for i in group.indices]


def clock_name(group) -> str:
    return f"{group.name}_clock"


def definition(trim_x, rod_length: float | None, version: str, suite: Suite = LOAD_SUITE, clocked: bool = False) -> FmuDefinition:
    """The variable table; clocked: the FMI 3.0 variant with a periodic input clock per group (its interval the
    group's period, so no period parameters), each group's held samples clocked by it."""
    names, units, groups = _state_names(suite), _state_units(suite), suite.groups
    v = [Variable(n, "Real", "input", float(trim_x[i]), f"true state {n} (from the plant)", units[i])
         for i, n in enumerate(names)]
    v += [Variable(f"exact_{n}", "Real", "output", 0.0, f"{n}: exact state channel", units[i])
          for i, n in enumerate(names)]
    for g in groups:
        v += [Variable(n, "Real", "output", 0.0, f"{n}: {g.name} sample (held)", u, discrete=True,
                       clock=clock_name(g) if clocked else "")
              for n, u in zip(channel_names(g, suite), channel_units(g, suite))]
    if not clocked:
        v += [Variable(f"{g.name}_period", "Real", "parameter", g.period, f"{g.name} sampling period", "s") for g in groups]
    for g in groups:
        gu = channel_units(g, suite)
        v += [Variable(n, "Real", "parameter", b, f"{g.name} noise bound (3 sigma if gaussian, half-width if uniform)", gu[i])
              for i, (n, b) in enumerate(zip(bound_names(g, suite), g.bounds))]
    v.append(Variable("step", "Real", "parameter", TICK, "tick: the communication step the suite expects", "s"))
    if rod_length is not None:
        v.append(Variable("l", "Real", "parameter", rod_length, "rod length, as in the plant", "m"))
    # tunable: noise is a function of (seed, group, tick, channel), so a new seed gives new noise from the next sample
    # on (a branch from a snapshot draws other noise after it)
    v.append(Variable("seed", "Integer", "parameter", 1, "seed of every noise stream (0 .. 2147483647)", tunable=True))
    v += [Variable(f"{g.name}_pdf", "String", "parameter", g.pdf, f"{g.name} noise distribution: gaussian or uniform")
          for g in groups]
    v += [Variable(f"{g.name}_new", "Boolean", "output", False, f"{g.name} took a new sample this step") for g in groups]
    clocks = tuple(Clock(clock_name(g), float(g.period), f"{g.name} sampling (Table 5.8)") for g in groups) if clocked else ()
    return FmuDefinition(suite.model_identifier, suite.description, v, "sensor_model.h", (0.0, 1.2, TICK),
                         variable_step=False, version=version, clocks=clocks)


def group_table(definition: FmuDefinition, params, l_index: int | None, suite: Suite = LOAD_SUITE) -> str:
    """sensor_groups.h: each group's channels and variables by value reference, and the model's parameters."""
    vr = definition.vr
    clocks = [k.name for k in definition.clocks]
    rows = []
    for g in suite.groups:
        idx = ", ".join(map(str, g.indices))
        period = vr(f"{g.name}_period") if not clocks else -1
        clock = clocks.index(clock_name(g)) if clocks else -1
        rows.append(f'  {{"{g.name}", {int(g.source == "pi")}, {len(g.indices)}, {{{idx}}}, {vr(channel_names(g, suite)[0])}, '
                    f'{period}, {clock}, {vr(bound_names(g, suite)[0])}, {len(g.bounds)}, {vr(f"{g.name}_pdf")}, '
                    f'{vr(f"{g.name}_new")}}}')
    p = ", ".join(repr(float(x)) for x in params)
    return "\n".join([
        f"/* Generated from tiltload.sensor_fmu.suite ({suite.vehicle} suite): do not edit. */",
        "#ifndef SENSOR_GROUPS_H", "#define SENSOR_GROUPS_H", "",
        f"#define TL_N_GROUPS {len(suite.groups)}", f"#define TL_N_PARAMS {len(params)}",
        f"#define TL_SENSOR_NX {VEHICLES[suite.vehicle].nx}", f"#define TL_SENSOR_NY {len(suite.pi_names)}",
        f"#define TL_HAS_ROD {int(l_index is not None)}", f"#define TL_L_INDEX {l_index if l_index is not None else -1}", "",
        "typedef struct {",
        "  const char* name;",
        "  int from_pi;   /* samples pi(x) (4.22), else q */",
        "  int n;         /* channels */",
        "  int index[16]; /* entries of pi(x) or q */",
        "  int out;       /* value reference of the first held sample (the rest follow) */",
        "  int period;    /* value reference of the period parameter (-1: the clocked variant, whose clock is the period) */",
        "  int clock;     /* index of the group's clock (-1: the plain variant) */",
        "  int bound;     /* value reference of the first bound */",
        "  int n_bounds;  /* 1: one bound for all channels, else one each */",
        "  int pdf;       /* String value reference of the distribution */",
        "  int flag;      /* Boolean value reference of the new-sample flag */",
        "} TlSensorGroup;", "",
        "static const TlSensorGroup tl_sensor_groups[TL_N_GROUPS] = {", ",\n".join(rows), "};", "",
        "/* Table 5.1 parameters pi(x) is evaluated with; the rod length comes from the l parameter. */",
        f"static const double tl_sensor_p0[TL_N_PARAMS] = {{{p}}};", "", "#endif", ""])
