"""STL formulas in rtamt's textual grammar (the subset tiltload monitors), parsed by recursive descent.

    formula   := implies
    implies   := or [ ('implies' | '->') implies ]              right-associative
    or        := and { ('or' | '||' | '|') and }
    and       := until { ('and' | '&&' | '&') until }
    until     := unary [ 'until' [interval] unary ]
    unary     := ('not' | '!') unary | ('always' | 'G') [interval] unary | ('eventually' | 'F') [interval] unary
               | comparison | '(' formula ')'
    comparison:= expr ('<' | '<=' | '>' | '>=' | '==' | '!==' | '!=') expr
    expr      := term { ('+' | '-') term } ;  term := factor { ('*' | '/') factor }
    factor    := '-' factor | NUMBER | SIGNAL | 'abs' '(' expr ')' | '(' expr ')'
    interval  := '[' NUMBER ':' (NUMBER | 'inf') ']'           seconds, closed; inf or no interval: to the end of the run

A signal is `instance.variable` (letters, digits, _ and dots). A parse error is one line with the position marked.
"""

from __future__ import annotations

import math
import re
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
KEYWORDS = {"always": "always", "G": "always", "eventually": "eventually", "F": "eventually", "until": "until",
            "not": "not", "and": "and", "or": "or", "implies": "implies", "abs": "abs"}
_TOKEN = re.compile(r"""\s*(?:
    (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*)*)
  | (?P<op>!==|==|!=|<=|>=|->|&&|\|\||[<>()\[\]:+\-*/!&|])
)""", re.VERBOSE)
_SYMBOLS = {"!": "not", "->": "implies", "&&": "and", "&": "and", "||": "or", "|": "or", "!=": "!=="}


@dataclass(frozen=True)
class _Tok:
    kind: str  # number, name, keyword, op, end
    text: str
    pos: int


def _tokens(text: str) -> list[_Tok]:
    out, pos = [], 0
    while True:
        while pos < len(text) and text[pos].isspace():
            pos += 1
        if pos == len(text):
            out.append(_Tok("end", "", pos))
            return out
        m = _TOKEN.match(text, pos)
        if m is None or m.end() == pos:
            raise _error(text, pos, f"unexpected character {text[pos]!r}")
        kind = m.lastgroup
        word = m.group(kind)
        start = m.start(kind)
        if kind == "name" and word in KEYWORDS:
            out.append(_Tok("keyword", KEYWORDS[word], start))
        elif kind == "op" and word in _SYMBOLS:
            out.append(_Tok("keyword" if _SYMBOLS[word] in KEYWORDS else "op", _SYMBOLS[word], start))
        else:
            out.append(_Tok(kind, word, start))
        pos = m.end()


def _error(text: str, pos: int, why: str) -> StlError:
    """One line: the problem, then the formula with a marker before the offending position."""
    return StlError(f"{why} at column {pos + 1}: {text[:pos]}\u2192{text[pos:]}".rstrip())


class _Parser:
    def __init__(self, text: str) -> None:
        self.text, self.toks, self.i = text, _tokens(text), 0

    @property
    def tok(self) -> _Tok:
        return self.toks[self.i]

    def fail(self, why: str, tok: _Tok | None = None) -> StlError:
        tok = tok or self.tok
        found = "the end of the formula" if tok.kind == "end" else repr(tok.text)
        return _error(self.text, tok.pos, f"{why}, found {found}")

    def accept(self, kind: str, text: str | None = None) -> _Tok | None:
        t = self.tok
        if t.kind == kind and (text is None or t.text == text):
            self.i += 1
            return t
        return None

    def expect(self, kind: str, text: str, what: str) -> _Tok:
        t = self.accept(kind, text)
        if t is None:
            raise self.fail(f"expected {what}")
        return t

    def formula(self):
        f = self.implies()
        if self.tok.kind != "end":
            raise self.fail("expected an operator or the end of the formula")
        return f

    def implies(self):
        left = self.disjunction()
        if self.accept("keyword", "implies"):
            return Implies(left, self.implies())
        return left

    def disjunction(self):
        f = self.conjunction()
        while self.accept("keyword", "or"):
            f = Or(f, self.conjunction())
        return f

    def conjunction(self):
        f = self.until()
        while self.accept("keyword", "and"):
            f = And(f, self.until())
        return f

    def until(self):
        left = self.unary()
        if self.accept("keyword", "until"):
            a, b = self.interval()
            return Until(a, b, left, self.unary())
        return left

    def unary(self):
        if self.accept("keyword", "not"):
            return Not(self.unary())
        for word, node in (("always", Always), ("eventually", Eventually)):
            if self.accept("keyword", word):
                a, b = self.interval()
                return node(a, b, self.unary())
        if self.tok.kind == "op" and self.tok.text == "(":
            start = self.i  # a parenthesis opens a formula or an arithmetic expression: try the comparison first
            try:
                return self.comparison()
            except StlError:
                self.i = start
            self.i += 1
            f = self.implies()
            self.expect("op", ")", "')'")
            return f
        return self.comparison()

    def interval(self) -> tuple[float, float]:
        if not self.accept("op", "["):
            return 0.0, math.inf
        open_tok = self.toks[self.i - 1]
        a = self.number("the interval's start (seconds)")
        self.expect("op", ":", "':' between the interval's bounds")
        b = math.inf if self.accept("name", "inf") else self.number("the interval's end (seconds, or inf)")
        self.expect("op", "]", "']' closing the interval")
        if b < a:
            raise _error(self.text, open_tok.pos, f"reversed interval [{a:g}:{b:g}]: the end must not come before the start")
        return a, b

    def number(self, what: str) -> float:
        neg = self.accept("op", "-")
        t = self.accept("number")
        if t is None:
            raise self.fail(f"expected {what}")
        if neg:
            raise _error(self.text, neg.pos, f"negative time bound -{t.text}: STL's intervals look forward, from 0 up")
        return float(t.text)

    def comparison(self):
        left = self.expr()
        t = self.tok
        if t.kind == "op" and t.text in ("<", "<=", ">", ">=", "==", "!=="):
            self.i += 1
            return Compare(t.text, left, self.expr())
        raise self.fail("expected a comparison (<, <=, >, >=, ==, !==)")

    def expr(self):
        e = self.term()
        while self.tok.kind == "op" and self.tok.text in "+-":
            op = self.tok.text
            self.i += 1
            e = Arith(op, (e, self.term()))
        return e

    def term(self):
        e = self.factor()
        while self.tok.kind == "op" and self.tok.text in "*/":
            op = self.tok.text
            self.i += 1
            e = Arith(op, (e, self.factor()))
        return e

    def factor(self):
        if self.accept("op", "-"):
            if t := self.accept("number"):  # a negative constant is one number
                return Const(-float(t.text))
            return Arith("neg", (self.factor(),))
        if t := self.accept("number"):
            return Const(float(t.text))
        if t := self.accept("name"):
            if "." not in t.text:
                raise _error(self.text, t.pos, f"signal '{t.text}' is not instance.variable (e.g. plant.x)")
            return Signal(t.text)
        if self.accept("keyword", "abs"):
            self.expect("op", "(", "'(' after abs")
            e = self.expr()
            self.expect("op", ")", "')' closing abs(")
            return Arith("abs", (e,))
        if self.accept("op", "("):
            e = self.expr()
            self.expect("op", ")", "')'")
            return e
        raise self.fail("expected a number, a signal (instance.variable), abs( or '('")


def parse(text: str):
    """The formula's syntax tree; StlError (one line, the position marked) if it does not parse."""
    if not text.strip():
        raise StlError("empty formula")
    return _Parser(text).formula()


def signals(node) -> list[str]:
    """The signal names a formula reads, in order of first appearance."""
    out: dict[str, None] = {}

    def walk(n) -> None:
        if isinstance(n, Signal):
            out[n.name] = None
        for child in children(n):
            walk(child)
    walk(node)
    return list(out)


def children(node) -> tuple:
    if isinstance(node, Arith):
        return node.args
    if isinstance(node, (Compare, And, Or, Implies, Until)):
        return (node.left, node.right)
    if isinstance(node, (Not, Always, Eventually)):
        return (node.arg,)
    return ()


def horizon(node) -> float:
    """How far past the evaluation time the formula looks (s); inf for an operator to the end of the run."""
    if isinstance(node, (Always, Eventually)):
        return node.b + horizon(node.arg)
    if isinstance(node, Until):
        return node.b + max(horizon(node.left), horizon(node.right))
    return max((horizon(c) for c in children(node)), default=0.0)


def bounded_horizon(node) -> float:
    """The horizon counting only bounded intervals (an unbounded operator runs to the end of whatever trace there is)."""
    if isinstance(node, (Always, Eventually, Until)):
        own = node.b if math.isfinite(node.b) else node.a
        return own + max((bounded_horizon(c) for c in children(node)), default=0.0)
    return max((bounded_horizon(c) for c in children(node)), default=0.0)


def _num(v: float) -> str:
    """The shortest text that reads back as the same float."""
    short = f"{v:g}"
    return short if float(short) == v else repr(v)


def unparse(node) -> str:
    """rtamt's textual form of a tree (fully parenthesized): what --explain shows."""
    def iv(n) -> str:
        return "" if n.a == 0 and math.isinf(n.b) else f"[{_num(n.a)}:{'inf' if math.isinf(n.b) else _num(n.b)}]"
    if isinstance(node, Signal):
        return node.name
    if isinstance(node, Const):
        return _num(node.value) if node.value >= 0 else f"({_num(node.value)})"
    if isinstance(node, Arith):
        if node.op == "neg":
            return f"-({unparse(node.args[0])})"
        if node.op == "abs":
            return f"abs({unparse(node.args[0])})"
        return f"({unparse(node.args[0])} {node.op} {unparse(node.args[1])})"
    if isinstance(node, Compare):
        return f"{unparse(node.left)} {node.op} {unparse(node.right)}"
    if isinstance(node, Not):
        return f"not ({unparse(node.arg)})"
    if isinstance(node, (And, Or, Implies)):
        word = {And: "and", Or: "or", Implies: "implies"}[type(node)]
        return f"({unparse(node.left)}) {word} ({unparse(node.right)})"
    if isinstance(node, Always):
        return f"always{iv(node)} ({unparse(node.arg)})"
    if isinstance(node, Eventually):
        return f"eventually{iv(node)} ({unparse(node.arg)})"
    if isinstance(node, Until):
        return f"({unparse(node.left)}) until{iv(node)} ({unparse(node.right)})"
    raise TypeError(node)
