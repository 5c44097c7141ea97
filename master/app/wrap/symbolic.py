"""A traced array for numpy: a controller written in plain numpy runs on CasADi symbols unchanged (DESIGN §18).

`Sym` holds a numpy object array of CasADi SX scalars, so numpy itself does shapes, indexing, slicing, broadcasting,
reshapes and concatenations; numpy hands its ufuncs (NEP 13: `np.sin`, `np.maximum`, comparisons, ...) and its
functions (NEP 18: `np.clip`, `np.where`, `np.concatenate`, ...) to `Sym`, which answers with symbols.

What numpy's protocols cannot reach is bound while a class is traced (tracing_scope.py's `tracing`):
- `float(x)` and `int(x)` in the class's module: a traced value handed on stays a symbol (`int` truncates). A real
  float cannot hold a symbol, so `float` there is a subclass of float whose constructor returns the symbol when given
  one (and `isinstance(v, float)` still answers for real floats);
- `math` (and names imported from it) in the class's module: the same functions on symbols;
- `np.array`, `np.asarray`, `np.asanyarray` of traced values (anywhere, so tiltload's helpers trace too), and
  `np.zeros`/`ones`/`empty`/`full` called from the class's file (so `u = np.zeros(4); u[0] = thrust` holds symbols).
A Python decision on a traced value (`if x > 0:`) raises a TypeError whose text says "truth value"."""

from __future__ import annotations

import builtins
import math
import operator
import warnings
from functools import reduce

import casadi as ca
import numpy as np

REFUSED = "a traced value turned into a number"  # trace._operation words what the user wrote instead
ORIGINAL = {n: getattr(np, n) for n in ("array", "asarray", "asanyarray", "zeros", "ones", "empty", "full")}


def _sx(v) -> ca.SX:
    """One element as an SX scalar."""
    if isinstance(v, ca.SX):
        return v
    if isinstance(v, Sym):
        if v.a.size != 1:
            raise TypeError("an array where one value is expected")
        return v.a.reshape(())[()]
    if isinstance(v, (bool, np.bool_)):
        return ca.SX(1.0 if v else 0.0)
    return ca.SX(builtins.float(v))


_TO_SX = np.frompyfunc(_sx, 1, 1)


def _scalar(v) -> np.ndarray:
    a = ORIGINAL["empty"]((), dtype=object)
    a[()] = v
    return a


def elements(x) -> np.ndarray:
    """Any operand (Sym, SX, number, array, nested lists of these) as a numpy object array of SX scalars."""
    if isinstance(x, Sym):
        return x.a
    if isinstance(x, ca.SX):
        if x.is_scalar():
            return _scalar(x)
        rows = ORIGINAL["empty"](x.shape, dtype=object)
        for i, j in np.ndindex(*x.shape):
            rows[i, j] = x[i, j]
        return rows[:, 0] if x.shape[1] == 1 else rows
    if isinstance(x, (list, tuple)):
        if not x:
            return ORIGINAL["empty"]((0,), dtype=object)
        return np.stack([elements(e) for e in x])
    a = ORIGINAL["asarray"](x)
    if a.dtype.kind not in "fiub" and a.dtype != object:
        raise TypeError(f"{x!r:.40} is not a number")
    return _scalar(_sx(a[()])) if a.shape == () else ORIGINAL["asarray"](_TO_SX(a), dtype=object)


def traced(x) -> bool:
    """Whether x is, or holds, a traced value."""
    if isinstance(x, (Sym, ca.SX)):
        return True
    if isinstance(x, (list, tuple)):
        return any(traced(e) for e in x)
    if isinstance(x, np.ndarray) and x.dtype == object:
        return any(traced(e) for e in x.ravel())
    return False


def _wrap(r):
    """numpy's answer on object arrays as a Sym (object arrays and SX scalars); numbers left as they are."""
    if isinstance(r, np.ndarray) and r.dtype == object:
        return Sym(ORIGINAL["asarray"](_TO_SX(r), dtype=object) if r.size else r)
    if isinstance(r, ca.SX):
        return Sym(elements(r))
    if isinstance(r, tuple):
        return tuple(_wrap(v) for v in r)
    if isinstance(r, list):
        return [_wrap(v) for v in r]
    return r


def _scalar_like(v) -> bool:
    return (isinstance(v, Sym) and v.a.ndim == 0) or (isinstance(v, ca.SX) and v.is_scalar()) or (
        isinstance(v, (int, float, np.number)) and not isinstance(v, bool))


def _unwrap(x):
    """An argument of a numpy function as numpy takes it: traced values as object arrays (a list of scalars one
    array, a list of arrays, as np.concatenate takes them, a list of arrays)."""
    if isinstance(x, Sym):
        return x.a
    if isinstance(x, ca.SX):
        return elements(x)
    if isinstance(x, (list, tuple)) and traced(x):
        if all(_scalar_like(v) for v in x):
            return elements(list(x))
        return type(x)(elements(v) if traced(v) else _unwrap(v) for v in x)
    return x


def _logic(fn):
    return lambda *a: fn(*(v != 0 for v in a))


_UFUNCS = {
    np.add: operator.add, np.subtract: operator.sub, np.multiply: operator.mul, np.true_divide: operator.truediv,
    np.negative: operator.neg, np.positive: operator.pos, np.power: operator.pow, np.float_power: operator.pow,
    np.absolute: ca.fabs, np.fabs: ca.fabs, np.sign: ca.sign, np.sqrt: ca.sqrt, np.square: lambda a: a * a,
    np.reciprocal: lambda a: 1 / a, np.exp: ca.exp, np.expm1: ca.expm1, np.exp2: lambda a: 2 ** a, np.log: ca.log,
    np.log10: ca.log10, np.log2: lambda a: ca.log(a) / math.log(2), np.log1p: ca.log1p, np.sin: ca.sin,
    np.cos: ca.cos, np.tan: ca.tan, np.arcsin: ca.asin, np.arccos: ca.acos, np.arctan: ca.atan, np.arctan2: ca.atan2,
    np.sinh: ca.sinh, np.cosh: ca.cosh, np.tanh: ca.tanh, np.arcsinh: ca.asinh, np.arccosh: ca.acosh,
    np.arctanh: ca.atanh, np.hypot: lambda a, b: ca.sqrt(a * a + b * b), np.floor: ca.floor, np.ceil: ca.ceil,
    np.trunc: lambda a: ca.sign(a) * ca.floor(ca.fabs(a)), np.maximum: ca.fmax, np.fmax: ca.fmax,
    np.minimum: ca.fmin, np.fmin: ca.fmin, np.fmod: ca.fmod, np.copysign: ca.copysign,
    np.deg2rad: lambda a: a * (math.pi / 180), np.radians: lambda a: a * (math.pi / 180),
    np.rad2deg: lambda a: a * (180 / math.pi), np.degrees: lambda a: a * (180 / math.pi),
    np.greater: operator.gt, np.greater_equal: operator.ge, np.less: operator.lt, np.less_equal: operator.le,
    np.equal: operator.eq, np.not_equal: operator.ne, np.logical_and: _logic(ca.logic_and),
    np.logical_or: _logic(ca.logic_or), np.logical_not: _logic(ca.logic_not), np.bitwise_and: _logic(ca.logic_and),
    np.bitwise_or: _logic(ca.logic_or), np.invert: _logic(ca.logic_not),
    np.logical_xor: lambda a, b: (a != 0) != (b != 0),
}
_ELEMENTWISE = {u: np.frompyfunc(f, u.nin, 1) for u, f in _UFUNCS.items()}


def _clip(a, a_min=None, a_max=None, out=None, **kwargs):
    if out is not None:
        raise TypeError(f"{REFUSED} (np.clip(..., out=) into an array of numbers)")
    x = elements(a)
    if a_min is not None:
        x = _ELEMENTWISE[np.maximum](x, elements(a_min))
    if a_max is not None:
        x = _ELEMENTWISE[np.minimum](x, elements(a_max))
    return _wrap(_ensure(x))


def _ensure(x):
    return x if isinstance(x, np.ndarray) else _scalar(x)


_IF_ELSE = np.frompyfunc(lambda c, a, b: ca.if_else(c != 0, a, b), 3, 1)


def _where(condition, *branches):
    if len(branches) != 2:
        raise TypeError("np.where(condition) (the indices where it holds) is a Python decision on a traced value: "
                        "truth value unknown; use np.where(condition, a, b)")
    return _wrap(_ensure(_IF_ELSE(elements(condition), elements(branches[0]), elements(branches[1]))))


def _extreme(fn):
    pairwise = np.frompyfunc(fn, 2, 1)

    def extreme(a, axis=None, out=None, keepdims=False, **kwargs):
        if out is not None or kwargs.get("initial") is not None or kwargs.get("where") is not None:
            raise TypeError(f"{REFUSED} (np.max/np.min with out, initial or where)")
        x = elements(a)
        if axis is None:
            return _wrap(_scalar(reduce(fn, x.ravel())))
        return _wrap(_ensure(pairwise.reduce(x, axis=axis, keepdims=keepdims)))
    return extreme


def _norm(x, ord=None, axis=None, keepdims=False):
    if ord not in (None, 2, "fro") or axis is not None:
        raise TypeError(f"{REFUSED} (np.linalg.norm with ord or axis: write it as np.sqrt(np.sum(x**2)))")
    e = elements(x).ravel()
    return _wrap(_scalar(ca.sqrt(reduce(operator.add, (v * v for v in e), ca.SX(0.0)))))


_FUNCTIONS = {np.clip: _clip, np.where: _where, np.max: _extreme(ca.fmax), np.amax: _extreme(ca.fmax),
              np.min: _extreme(ca.fmin), np.amin: _extreme(ca.fmin), np.linalg.norm: _norm}
_REFUSED_FUNCTIONS = {np.argmax, np.argmin, np.sort, np.argsort, np.nonzero, np.any, np.all, np.isnan, np.isfinite,
                      np.isinf, np.round, np.around, np.unique, np.linalg.solve, np.linalg.inv}


class Sym:
    """A traced numpy array (any shape; shape () for a scalar) of CasADi SX scalars."""

    __slots__ = ("a",)
    __hash__ = None

    def __init__(self, a: np.ndarray):
        self.a = a

    # numpy's protocols
    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        out = kwargs.pop("out", None)
        if method != "__call__" or ufunc not in _ELEMENTWISE or {k for k in kwargs if kwargs[k] is not None} - {"dtype"}:
            raise TypeError(f"np.{ufunc.__name__}{'' if method == '__call__' else '.' + method} of a traced value: "
                            f"{REFUSED}")
        result = _wrap(_ensure(_ELEMENTWISE[ufunc](*(elements(v) for v in inputs))))
        if out is not None:  # x += y into an array: only a traced array can hold the symbols
            target = out[0]
            if not isinstance(target, Sym):
                raise TypeError(f"{REFUSED} (a traced value stored into an array of numbers: make the array with "
                                "np.zeros/np.array while tracing, or build it from the values)")
            target.a[...] = result.a
            return target
        return result

    def __array_function__(self, func, types, args, kwargs):
        if func in _FUNCTIONS:
            return _FUNCTIONS[func](*args, **kwargs)
        if func in _REFUSED_FUNCTIONS:
            raise TypeError(f"np.{func.__name__} of a traced value needs its number: truth value unknown")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return _wrap(func(*(_unwrap(a) for a in args), **{k: _unwrap(v) for k, v in kwargs.items()}))

    def __array__(self, dtype=None, copy=None):
        if all(v.is_constant() for v in self.a.ravel()):
            return ORIGINAL["array"]([builtins.float(v) for v in self.a.ravel()]).reshape(self.a.shape)
        raise TypeError(REFUSED)

    def __SX__(self):  # CasADi's functions take a Sym as they take an SX (ca.fmax(x, 0) in code written for CasADi)
        if self.a.ndim == 0:
            return self.a[()]
        m = self.a if self.a.ndim == 2 else self.a.reshape(-1, 1)
        return ca.vertcat(*[ca.horzcat(*row) for row in m]) if m.size else ca.SX(*m.shape)

    # an array's face
    shape = property(lambda self: self.a.shape)
    ndim = property(lambda self: self.a.ndim)
    size = property(lambda self: self.a.size)
    T = property(lambda self: Sym(self.a.T))
    dtype = property(lambda self: np.dtype(float))

    def __len__(self):
        return len(self.a)

    def __iter__(self):
        return (_wrap(_ensure(v)) for v in self.a)

    def __getitem__(self, key):
        return _wrap(_ensure(self.a[_unwrap(key)]))

    def __setitem__(self, key, value):
        self.a[_unwrap(key)] = elements(value)

    def __repr__(self):
        return f"Sym({self.a!r})"

    def copy(self):
        return Sym(self.a.copy())

    def reshape(self, *shape, **kwargs):
        return Sym(self.a.reshape(*shape, **kwargs))

    def ravel(self):
        return Sym(self.a.ravel())

    flatten = ravel

    def transpose(self, *axes):
        return Sym(self.a.transpose(*axes))

    def astype(self, dtype=None, **kwargs):
        return self.copy()

    def item(self, *index):  # the SX itself: CasADi's conversions call item() on what looks like a numpy scalar
        return self.a.item(*index)

    def tolist(self):
        return [v.tolist() for v in self] if self.a.ndim else self

    def sum(self, *args, **kwargs):
        return np.sum(self, *args, **kwargs)

    def mean(self, *args, **kwargs):
        return np.mean(self, *args, **kwargs)

    def max(self, *args, **kwargs):
        return np.max(self, *args, **kwargs)

    def min(self, *args, **kwargs):
        return np.min(self, *args, **kwargs)

    def clip(self, a_min=None, a_max=None):
        return np.clip(self, a_min, a_max)

    def dot(self, other):
        return np.dot(self, other)

    # a number's face: a decision, or a conversion outside the class's module, needs the number
    def __bool__(self):
        if self.a.size == 1 and self.a.reshape(())[()].is_constant():
            return builtins.float(self.a.reshape(())[()]) != 0.0
        raise TypeError("the truth value of a traced value is unknown while tracing")

    def __float__(self):
        raise TypeError(REFUSED)

    __int__ = __index__ = __complex__ = __float__

    def __round__(self, ndigits=None):
        raise TypeError(f"{REFUSED} (round(): write np.floor(x + 0.5) or leave the rounding to the plant)")

    # arithmetic: numpy's ufuncs, so broadcasting is numpy's
    __add__ = lambda s, o: np.add(s, o)  # noqa: E731
    __radd__ = lambda s, o: np.add(o, s)  # noqa: E731
    __sub__ = lambda s, o: np.subtract(s, o)  # noqa: E731
    __rsub__ = lambda s, o: np.subtract(o, s)  # noqa: E731
    __mul__ = lambda s, o: np.multiply(s, o)  # noqa: E731
    __rmul__ = lambda s, o: np.multiply(o, s)  # noqa: E731
    __truediv__ = lambda s, o: np.true_divide(s, o)  # noqa: E731
    __rtruediv__ = lambda s, o: np.true_divide(o, s)  # noqa: E731
    __pow__ = lambda s, o: np.power(s, o)  # noqa: E731
    __rpow__ = lambda s, o: np.power(o, s)  # noqa: E731
    __neg__ = lambda s: np.negative(s)  # noqa: E731
    __pos__ = lambda s: s  # noqa: E731
    __abs__ = lambda s: np.absolute(s)  # noqa: E731
    __lt__ = lambda s, o: np.less(s, o)  # noqa: E731
    __le__ = lambda s, o: np.less_equal(s, o)  # noqa: E731
    __gt__ = lambda s, o: np.greater(s, o)  # noqa: E731
    __ge__ = lambda s, o: np.greater_equal(s, o)  # noqa: E731
    __eq__ = lambda s, o: np.equal(s, o)  # noqa: E731
    __ne__ = lambda s, o: np.not_equal(s, o)  # noqa: E731
    __and__ = __rand__ = lambda s, o: np.logical_and(s, o)  # noqa: E731
    __or__ = __ror__ = lambda s, o: np.logical_or(s, o)  # noqa: E731
    __invert__ = lambda s: np.logical_not(s)  # noqa: E731

    def __matmul__(self, other):
        return _wrap(np.matmul(self.a, elements(other)))

    def __rmatmul__(self, other):
        return _wrap(np.matmul(elements(other), self.a))

    def __floordiv__(self, other):
        return np.floor(np.true_divide(self, other))

    def __rfloordiv__(self, other):
        return np.floor(np.true_divide(other, self))


def symbols(name: str, shape: tuple[int, ...], names: list[str]) -> Sym:
    """A Sym of fresh SX symbols, one per element, named as the FMU names them."""
    a = ORIGINAL["empty"](len(names), dtype=object)
    for i, n in enumerate(names):
        a[i] = ca.SX.sym(n)
    return Sym(a.reshape(shape))


def flat(value) -> list[ca.SX]:
    """The SX scalars of a traced value (Sym, SX, a number, or nested lists, tuples and arrays of these)."""
    if isinstance(value, (list, tuple)):
        return [s for v in value for s in flat(v)]
    if isinstance(value, np.ndarray) and value.dtype == object:
        return [s for v in value.ravel() for s in flat(v)]
    return list(elements(value).ravel())


__all__ = ["ORIGINAL", "REFUSED", "Sym", "elements", "flat", "symbols", "traced"]
