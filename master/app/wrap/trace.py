"""A Python controller traced into CasADi functions, so its step can be generated as C (DESIGN §17, §18).

The class's __init__ runs first on symbols for its declared `parameters` (so what it derives from them is recomputed
when they are set); where it needs their numbers (a design by a solver, a Python branch on one) it runs on the
numbers and those parameters are fixed in the FMU (said at wrap time). The numbers it leaves (floats, ints, numpy
arrays of numbers) become FMU parameters too, each element a Real named after the attribute (K_0_3 for K[0, 3]). Then
`step(t, inputs)` runs once on traced arrays (symbolic.py): plain numpy (arithmetic, `@`, indexing, assignment,
`np.clip`, `np.where`, elementwise functions, `float()`, `math.*`) gives symbols, and what it returns is the command.
An attribute that step assigns is a discrete state, held between ticks, starting from its value after __init__.

What cannot be traced: a Python decision on a value (`if x > 0:`, `min(x, y)`), which needs the number; tracing
refuses it in one line naming the line of the class and np.where."""

from __future__ import annotations

import math
import re
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from .no_io import IoInStep, NoIoInStep
from .symbolic import REFUSED, Sym, elements, flat, symbols, traced
from .tracing_scope import tracing
from .wrap import USER_ENDS, WrapError, user_line


class TraceError(WrapError):
    """A controller that cannot be traced; the message names the class, the line and the operation."""


class InitError(TraceError):
    """A controller whose __init__ raises: no route wraps it (the message names the class, the error and the line)."""


TIME_LIMIT_S = 60.0  # __init__ and the traced step each: a controller's take milliseconds; a loop without end never ends
MAX_NUMBERS = 65_536  # the numbers kept from __init__, each a parameter or state of the FMU (a gain matrix holds hundreds)


class _TooLong(BaseException):
    """Raised in the traced code at the time limit (a BaseException: the user's own `except Exception` lets it by)."""


WATCH = None  # in wrap's child process (sandbox.py): told (what, seconds) as each part of the user's code starts


@contextmanager
def time_limit(what: str, error: type[TraceError] = TraceError):
    """Run the block for at most TIME_LIMIT_S (SIGALRM's timer; off the main thread, unbounded). In wrap's child the
    parent is told too: its watchdog cuts what a signal cannot (a long call into C)."""
    import signal
    import threading

    if WATCH is not None:
        WATCH(what, TIME_LIMIT_S)
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def expired(signum, frame):
        raise _TooLong()

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
    try:
        yield
    except _TooLong:
        raise error(f"{what} did not return within {TIME_LIMIT_S:g} s (a loop without end?)") from None
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
        if WATCH is not None:
            WATCH("", 0.0)


@dataclass
class Traced:
    """The controller as one function: step(t, inputs, parameters, states) -> (command[4], next states)."""

    function: ca.Function
    inputs: list[str]
    parameters: list[tuple[str, float]]  # flattened numbers kept from __init__: (FMU name, value)
    states: list[tuple[str, float]]  # flattened attributes step assigns: (name, initial value at the defaults)
    init: ca.Function  # the states' initial values from the parameters (p -> s0)
    fixed: list[str]  # the declared parameters __init__ needs the numbers of: fixed at their defaults in the FMU
    why_fixed: str = ""


def _numbers(value) -> np.ndarray | None:
    """The value as a float array, if it is a number or an array (or nested list) of numbers; else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float, np.integer, np.floating)):
        return np.array(float(value))
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiu" and value.size <= 100_000:
        return value.astype(float)
    if isinstance(value, (list, tuple)) and value and all(
            isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) for v in value):
        return np.array(value, dtype=float)
    return None


def _element_names(name: str, shape: tuple[int, ...]) -> list[str]:
    if not shape:
        return [name]
    return [f"{name}_{'_'.join(map(str, idx))}" for idx in np.ndindex(*shape)]


@contextmanager
def _no_numbers_of_symbols():
    """float() of a symbol gives NaN in CasADi, silently: while tracing it is refused, where it happens."""
    original = ca.SX.__float__

    def refuse(value):
        if value.is_constant():
            return original(value)
        raise TypeError(f"{REFUSED} (float() of a CasADi value)")
    ca.SX.__float__ = refuse
    try:
        yield
    finally:
        ca.SX.__float__ = original


def _operation(err: BaseException) -> str:
    """What the traced code did that needs a number, in the user's words, and what to write instead."""
    text = str(err)
    if isinstance(err, SystemExit):
        return "it calls sys.exit(), which a controller's code may not"
    if "truth value" in text:
        return ("a Python decision on a traced value (if, while, and/or, min, max, sorted); write the choice with "
                "np.where(condition, a, b) (or np.minimum, np.maximum, np.clip, tl.saturate) (docs/ports.md)")
    if REFUSED in text or "setting an array element with a sequence" in text or "to_int" in text:
        return (f"{text.splitlines()[0]}: keep it an array expression (numpy's functions, tl.saturate, np.where), "
                "the number exists only when the FMU runs (docs/ports.md)")
    return f"{type(err).__name__}: {text.splitlines()[0] if text else ''}".rstrip(": ")


C_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")  # each number kept is an FMU variable, named in C and XML


def _check_names(name: str, numbers: dict[str, np.ndarray]) -> None:
    """Every number's FMU name a C identifier, and no two the same (self.K_0 beside self.K's first element)."""
    seen: dict[str, str] = {}
    for k, v in numbers.items():
        if not C_NAME.fullmatch(k):
            raise TraceError(f"{name}: self.{k!r} (set with setattr or __dict__) holds a number but its name is not an "
                             "identifier of letters, digits and _ (ASCII); each number kept becomes an FMU parameter "
                             "named after it: rename it")
        for element in _element_names(k, v.shape):
            if element in seen:
                raise TraceError(f"{name}: self.{k} and self.{seen[element]} both give the FMU parameter {element}; "
                                 "rename one")
            seen[element] = k


def instantiate(cls: type, parameters: dict[str, float], source: Path):
    """cls(**parameters), as the FMU will make it; InitError names the error and its line in the class's file."""
    try:
        with time_limit(f"{cls.__name__}()", InitError):
            return cls(**parameters) if parameters else cls()
    except TraceError:
        raise
    except SystemExit as err:
        where = f" at {line}" if (line := user_line(err, source)) else ""
        raise InitError(f"{cls.__name__}(): __init__ calls sys.exit({'' if err.code is None else repr(err.code)}){where}, "
                        "which a controller's code may not") from None
    except USER_ENDS as err:
        raise InitError(f"{cls.__name__}(): __init__ raised {type(err).__name__} ({err}) {user_line(err, source)}".rstrip()) from None


def _namespaces(cls: type) -> list[dict]:
    """The module namespaces of the class's functions (and its bases' from the same files): where float, int and
    math are bound to their symbolic forms while tracing."""
    seen: dict[int, dict] = {}
    for klass in cls.__mro__[:-1]:
        for value in vars(klass).values():
            g = getattr(value, "__globals__", None)
            if isinstance(g, dict):
                seen.setdefault(id(g), g)
    return list(seen.values())


def _symbolic_init(cls: type, declared: dict[str, ca.SX], source: Path, namespaces: list[dict]):
    """cls(**parameters) on symbols, so what __init__ derives from its parameters is recomputed when they are set; or
    (None, why) where __init__ needs their numbers (a design by a solver, a Python branch on one)."""
    name = cls.__name__
    given = {k: Sym(elements(s)) for k, s in declared.items()}
    try:
        with tracing(namespaces, str(source)), time_limit(f"{name}()", InitError):
            return cls(**given), ""
    except TraceError:
        raise
    except (*USER_ENDS, IoInStep) as err:
        where = user_line(err, source) or f"a line outside {source.name}"
        return None, f"{name}.__init__ needs the number at {where}"


def _kept(controller, declared: ca.SX, ints: bool = True) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The attributes kept: numbers (each element an FMU parameter) and expressions of the declared parameters."""
    numbers, derived = {}, {}
    for k, v in vars(controller).items():
        if not ints and isinstance(v, int) and not isinstance(v, bool):
            continue
        if traced(v):
            try:
                e = elements(v)
            except (TypeError, ValueError):
                continue
            if e.size and ca.depends_on(ca.vertcat(*e.ravel()), declared):
                derived[k] = e
            else:
                numbers[k] = np.array([float(ca.evalf(x)) for x in e.ravel()]).reshape(e.shape)
        elif (n := _numbers(v)) is not None:
            numbers[k] = n
    return numbers, derived


def step_once(controller, spec: dict, source: Path) -> None:
    """One step at t = 0 on the ports' start values (the hover trim), in Python, as the pythonfmu FMU will step it:
    a class that cannot run is refused at wrap time, not in a run."""
    name = spec["class"]
    inputs = {n: (bool(v[2]) if v[0] == "Boolean" else float(v[2])) for n, v in spec["inputs"].items()}
    try:
        with time_limit(f"{name}.step"):
            command = [float(v) for v in controller.step(0.0, inputs)]
    except TraceError:
        raise
    except USER_ENDS as err:
        where = user_line(err, source) or f"a line outside {source.name}"
        raise TraceError(f"{name}.step fails on the trim at t = 0 at {where}: {type(err).__name__} "
                         f"({str(err).splitlines()[0] if str(err) else ''})") from None
    if len(command) != 4 or not all(math.isfinite(v) for v in command):
        raise TraceError(f"{name}.step on the trim at t = 0 returns {command}; it must return 4 finite numbers "
                         "(f_R, f_L, tau_R, tau_L)")


def trace(cls: type, parameters: dict[str, float], inputs: list[str], source: Path) -> Traced:
    """Trace cls (its file: source) into one function; TraceError names what cannot be traced and where."""
    namespaces = _namespaces(cls)
    declared = {k: ca.SX.sym(k) for k in parameters}
    controller, fixed = _symbolic_init(cls, declared, source, namespaces) if parameters else (None, "")
    if controller is not None:
        try:
            return _trace(cls, controller, parameters, declared, "", inputs, source, namespaces)
        except InitError:
            raise
        except TraceError as err:  # step may need a number __init__ derived from a parameter (range(self.n)): fixed
            where = re.search(r"cannot be traced at (line \d+ \(`.*?`\))", str(err))
            fixed = f"{cls.__name__}.step needs the number at {where.group(1) if where else 'a line of step'}"
    try:
        return _trace(cls, instantiate(cls, parameters, source), parameters, declared, fixed, inputs, source, namespaces)
    except InitError:
        raise
    except TraceError as err:  # a count (range(self.n)): __init__'s ints kept as the numbers they are, if that traces
        try:
            return _trace(cls, instantiate(cls, parameters, source), parameters, declared,
                          fixed or (f"{cls.__name__}.step needs the number of one" if parameters else ""), inputs, source,
                          namespaces, ints=False)
        except TraceError:
            raise err from None


def _trace(cls: type, controller, parameters: dict[str, float], declared: dict[str, ca.SX], fixed: str,
           inputs: list[str], source: Path, namespaces: list[dict], ints: bool = True) -> Traced:
    """The trace of step on an instance (made on symbols, or on numbers with fixed saying why); ints=False keeps
    __init__'s ints as numbers (a count a loop runs to), not parameters."""
    name = cls.__name__
    declared_sx = ca.vertcat(*declared.values())
    numbers, derived = _kept(controller, declared_sx, ints)
    for k in [k for k in numbers if set(_element_names(k, numbers[k].shape)) & set(parameters)]:
        derived[k] = elements(numbers.pop(k))  # self.kp = kp of a declared parameter kp: the parameter's own name
    _check_names(name, numbers)
    if sum(v.size for v in numbers.values()) > MAX_NUMBERS:
        biggest = max(numbers, key=lambda k: numbers[k].size)
        raise TraceError(f"{name}: its numbers after __init__ are {sum(v.size for v in numbers.values()):,} (self.{biggest} "
                         f"holds {numbers[biggest].size:,}); at most {MAX_NUMBERS:,} are kept, each a parameter of the FMU")
    kept = {**numbers, **derived}
    syms = {k: symbols(k, v.shape, _element_names(k, v.shape)) for k, v in kept.items()}
    before = {k: list(s.a.ravel()) for k, s in syms.items()}
    for k, s in syms.items():
        setattr(controller, k, s)
    t = ca.SX.sym("t")
    u = {n: ca.SX.sym(n) for n in inputs}
    io = NoIoInStep(source)
    try:
        with _no_numbers_of_symbols(), tracing(namespaces, str(source)), time_limit(f"{name}.step"), io:
            command = controller.step(Sym(elements(t)), {n: Sym(elements(s)) for n, s in u.items()})
    except TraceError:
        raise
    except (*USER_ENDS, IoInStep) as err:
        if io.seen:  # the I/O refused, even where the user's own except swallowed it and went on
            raise TraceError(io.refusal(name)) from None
        where = user_line(err, source) or f"a line outside {source.name}"
        raise TraceError(f"{name}.step cannot be traced at {where}: {_operation(err)}") from None
    if io.seen:
        raise TraceError(io.refusal(name))
    try:
        out = flat(command)
        after = {k: flat(getattr(controller, k)) for k in kept}
    except (TypeError, ValueError) as err:  # a value that is not a number or a symbol (a string, None)
        raise TraceError(f"{name}.step: its command or a state is not a number ({str(err).splitlines()[0]})") from None
    if len(out) != 4:
        raise TraceError(f"{name}.step returns {len(out)} values; it must return (f_R, f_L, tau_R, tau_L)")
    changed = [k for k in kept if len(after[k]) != len(before[k])
               or any(not ca.is_equal(a, b) for a, b in zip(after[k], before[k]))]
    for k in changed:
        if len(after[k]) != len(before[k]):
            raise TraceError(f"{name}.step changes the shape of self.{k} ({kept[k].shape} -> {len(after[k])} values): "
                             "a state keeps its shape")
    fixed_numbers = [k for k in numbers if k not in changed]
    par_sx = [*declared.values(), *(s for k in fixed_numbers for s in before[k])]
    state_sx = [s for k in changed for s in before[k]]
    initial_sx = [ca.SX(x) for k in changed for x in kept[k].ravel()]  # numbers, or expressions of the parameters
    # an expression of the parameters that step only reads: the expression itself in the traced function
    inline = [k for k in derived if k not in changed]
    old = ca.vertcat(*(s for k in inline for s in before[k]))
    new = ca.vertcat(*(ca.SX(x) for k in inline for x in derived[k].ravel()))
    y, s_next = ca.vertcat(*out), ca.vertcat(*(s for k in changed for s in after[k]))
    if inline:
        y, s_next = ca.substitute([y, s_next], [old], [new])
    p = ca.vertcat(*par_sx)
    fn = ca.Function("tl_traced_step", [t, ca.vertcat(*u.values()), p, ca.vertcat(*state_sx)], [y, s_next],
                     ["t", "u", "p", "s"], ["y", "s_next"])
    init = ca.Function("tl_traced_init", [p], [ca.vertcat(*initial_sx)], ["p"], ["s0"])
    if fn.has_free() or init.has_free():
        raise TraceError(f"{name}.step uses symbols that are neither inputs nor numbers of the controller: "
                         f"{', '.join(fn.get_free() + init.get_free())}")
    params = [(k, float(v)) for k, v in parameters.items()]
    params += [(n, float(x)) for k in fixed_numbers for n, x in zip(_element_names(k, numbers[k].shape),
                                                                     numbers[k].ravel())]
    s0 = np.array(init([v for _, v in params])).ravel() if state_sx else []
    states = [(n, float(x)) for n, x in zip([n for k in changed for n in _element_names(k, kept[k].shape)], s0)]
    bad = [n for n, x in params + states if not math.isfinite(x)]
    if bad:
        raise TraceError(f"{name}: self.{bad[0]} is not finite after __init__")
    return Traced(fn, list(inputs), params, states, init, list(parameters) if fixed else [], fixed)


def run_traced(traced: Traced, t: float, inputs: dict[str, float], parameters: np.ndarray, states: np.ndarray):
    """One step of the traced function in Python (the reference the C is compared with)."""
    y, s = traced.function(t, [float(inputs[n]) for n in traced.inputs], parameters, states)
    return np.array(y).ravel(), np.array(s).ravel()


__all__ = ["InitError", "TraceError", "Traced", "instantiate", "run_traced", "step_once", "time_limit", "trace"]
