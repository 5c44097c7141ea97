"""The syntax tree of an STL formula (expressions give values, formulas give robustness) and the walks over it: its
nodes in order (postorder, children), the signals it reads, how far it looks ahead (horizon). Every walk uses an explicit
stack, so a chain thousands long is fine. The text it is read from and written back to: grammar.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


class StlError(ValueError):
    """A formula that does not parse or does not fit: the message is one line for the user."""


# --- the syntax tree: expressions give values, formulas give robustness -------------------------------------------

@dataclass(frozen=True)
class Signal:
    name: str


@dataclass(frozen=True)
class Const:
    value: float


@dataclass(frozen=True)
class Arith:
    op: str  # + - * / neg abs
    args: tuple


@dataclass(frozen=True)
class Compare:
    op: str  # < <= > >= == !==
    left: object
    right: object


@dataclass(frozen=True)
class Not:
    arg: object


@dataclass(frozen=True)
class And:
    left: object
    right: object


@dataclass(frozen=True)
class Or:
    left: object
    right: object


@dataclass(frozen=True)
class Implies:
    left: object
    right: object


@dataclass(frozen=True)
class Always:
    a: float
    b: float  # math.inf: to the end of the run
    arg: object


@dataclass(frozen=True)
class Eventually:
    a: float
    b: float
    arg: object


@dataclass(frozen=True)
class Until:
    a: float
    b: float
    left: object
    right: object


TEMPORAL = (Always, Eventually, Until)


def postorder(root):
    """Every node of a tree, each after its children (left to right): an explicit stack, for a tree of any depth."""
    stack = [(root, False)]
    while stack:
        node, expanded = stack.pop()
        if expanded:
            yield node
            continue
        stack.append((node, True))
        stack.extend((child, False) for child in reversed(children(node)))


def signals(node) -> list[str]:
    """The signal names a formula reads, in order of first appearance."""
    return list(dict.fromkeys(n.name for n in postorder(node) if isinstance(n, Signal)))


def children(node) -> tuple:
    if isinstance(node, Arith):
        return node.args
    if isinstance(node, (Compare, And, Or, Implies, Until)):
        return (node.left, node.right)
    if isinstance(node, (Not, Always, Eventually)):
        return (node.arg,)
    return ()


def _fold(root, own) -> float:
    """own(node) plus the largest of its children's folds (0 for none), bottom up without recursion."""
    done: dict[int, float] = {}
    stack = [(root, False)]
    while stack:  # postorder's walk inline: it runs at every verdict, on the online monitor's path
        node, expanded = stack.pop()
        kids = children(node)
        if expanded or not kids:
            done[id(node)] = own(node) + (max(done.pop(id(c)) for c in kids) if kids else 0.0)
        else:
            stack.append((node, True))
            stack.extend((c, False) for c in kids)
    return done[id(root)]


def horizon(node) -> float:
    """How far past the evaluation time the formula looks (s); inf for an operator to the end of the run."""
    return _fold(node, _own_horizon)


def bounded_horizon(node) -> float:
    """The horizon counting only bounded intervals (an unbounded operator runs to the end of whatever trace there is)."""
    return _fold(node, _own_bounded_horizon)


def _own_horizon(n) -> float:
    return n.b if isinstance(n, TEMPORAL) else 0.0


def _own_bounded_horizon(n) -> float:
    return (n.b if math.isfinite(n.b) else n.a) if isinstance(n, TEMPORAL) else 0.0

