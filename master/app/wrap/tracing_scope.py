"""The names bound while a class is traced (symbolic.py's Sym answers the rest): `float`, `int` and `math` in the
class's module, numpy's array constructors, and no third-party warning on the user's terminal meanwhile."""

from __future__ import annotations

import builtins
import math
import sys
import warnings
from contextlib import contextmanager

import numpy as np

from .symbolic import ORIGINAL, REFUSED, Sym, elements, traced


class _Kind(type):
    def __instancecheck__(cls, obj):
        return isinstance(obj, cls.__mro__[1])

    def __subclasscheck__(cls, sub):
        return issubclass(sub, cls.__mro__[1])


class TracedFloat(builtins.float, metaclass=_Kind):
    """`float` in the traced class's module: float(symbol) is the symbol, float(anything else) a float."""

    def __new__(cls, x=0.0):
        return Sym(elements(x).reshape(())) if traced(x) else builtins.float(x)


class TracedInt(builtins.int, metaclass=_Kind):
    """`int` in the traced class's module: int(symbol) truncates it symbolically."""

    def __new__(cls, x=0, *base):
        return np.trunc(Sym(elements(x).reshape(()))) if traced(x) else builtins.int(x, *base)


def _math_function(name: str, original):
    ufunc = {"fabs": np.fabs, "asin": np.arcsin, "acos": np.arccos, "atan": np.arctan, "atan2": np.arctan2,
             "asinh": np.arcsinh, "acosh": np.arccosh, "atanh": np.arctanh, "pow": np.power}.get(name) or getattr(
        np, name, None)

    def symbolic(*args):
        if any(traced(a) for a in args):
            if name == "log" and len(args) == 2:
                return np.log(args[0]) / np.log(args[1])
            if ufunc is None or name in ("isfinite", "isnan", "isinf", "isclose"):
                raise TypeError(f"{REFUSED} (math.{name})")
            return ufunc(*(a if isinstance(a, Sym) else Sym(elements(a)) for a in args))
        return original(*args)
    return symbolic


class _Math:
    """`math` in the traced class's module: its functions on symbols as on numbers."""

    def __getattr__(self, name):
        value = getattr(math, name)
        return _math_function(name, value) if callable(value) else value


_MATH = _Math()


@contextmanager
def tracing(namespaces: list[dict], source: str):
    """Bind the names above in the class's module namespaces (and numpy's constructors) for the block; no third-party
    warning (CasADi's notices about numpy) reaches the user's terminal meanwhile."""
    saved = []
    for ns in namespaces:
        for name, value in list(ns.items()):
            if value is math:
                saved.append((ns, name, value))
                ns[name] = _MATH
            elif getattr(value, "__module__", None) == "math" and callable(value):
                saved.append((ns, name, value))
                ns[name] = _math_function(name, value)
        for name, value in (("float", TracedFloat), ("int", TracedInt)):
            saved.append((ns, name, ns.get(name, _MISSING)))
            ns[name] = value

    def from_arrays(name):
        original = ORIGINAL[name]

        def symbolic(x, *args, **kwargs):
            return Sym(elements(x).copy()) if traced(x) else original(x, *args, **kwargs)
        return symbolic

    def from_source(name):  # np.zeros(4) in the class's file: an array that can hold symbols
        original = ORIGINAL[name]

        def symbolic(*args, **kwargs):
            made = original(*args, **kwargs)
            if sys._getframe(1).f_code.co_filename != source or made.dtype.kind not in "fiu":
                return made
            return Sym(elements(made))
        return symbolic

    for name in ("array", "asarray", "asanyarray"):
        setattr(np, name, from_arrays(name))
    for name in ("zeros", "ones", "empty", "full"):
        setattr(np, name, from_source(name))
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="casadi")
            warnings.filterwarnings("ignore", category=FutureWarning, module="casadi")
            yield
    finally:
        for name, original in ORIGINAL.items():
            setattr(np, name, original)
        for ns, name, value in reversed(saved):
            if value is _MISSING:
                ns.pop(name, None)
            else:
                ns[name] = value


_MISSING = object()
