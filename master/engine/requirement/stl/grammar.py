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

Bounded (docs/requirements.md, "Limits"): at most MAX_CHARS characters, MAX_DEPTH levels of nesting (parentheses and
prefix operators: the only recursion of the parser; chains of and, or, implies, + are loops) and MAX_NODES nodes. Every
walk of a tree (signals, horizon, unparse, the evaluation) uses an explicit stack, so a chain thousands long is fine.
The tree itself: syntax.py.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from .syntax import Always, And, Arith, Compare, Const, Eventually, Implies, Not, Or, Signal, StlError, Until, children, postorder

MAX_CHARS = 65536  # a formula is text a person writes; the whole requirement file is at most 1 MiB
MAX_DEPTH = 50  # levels of nesting: each costs the parser 5 Python frames at most, 250 of the 1000 Python allows
MAX_NODES = 10000  # signals, numbers and operators: the monitor keeps one array of the run's length per operator

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
    """One line: the problem, then the formula with a marker before the offending position (a long formula cut to the
    60 characters either side of it)."""
    before, after = text[max(0, pos - 60):pos], text[pos:pos + 60]
    before = before if pos <= 60 else "\u2026" + before
    after = after if pos + 60 >= len(text) else after + "\u2026"
    return StlError(f"{why} at column {pos + 1}: {before}\u2192{after}".rstrip())


class _Parser:
    def __init__(self, text: str) -> None:
        self.text, self.toks, self.i, self.depth = text, _tokens(text), 0, 0
        self.failed: dict[int, StlError] = {}  # token index of a '(' -> how the arithmetic in it failed

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
        parts = [self.disjunction()]  # a loop (a chain of thousands is no recursion), folded to the right
        while self.accept("keyword", "implies"):
            parts.append(self.disjunction())
        f = parts.pop()
        while parts:
            f = Implies(parts.pop(), f)
        return f

    def nested(self, tok: _Tok) -> _Parser:
        """`with self.nested(tok):` one level of nesting deeper (no Python frame of its own), refused past MAX_DEPTH
        long before the recursion limit."""
        if self.depth >= MAX_DEPTH:
            raise _error(self.text, tok.pos, f"nested deeper than {MAX_DEPTH} levels (parentheses, not, always, eventually, "
                                             f"-, abs): the limit of a formula")
        self.depth += 1
        return self

    def __enter__(self) -> None:
        pass

    def __exit__(self, *exc) -> None:
        self.depth -= 1

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
        if t := self.accept("keyword", "not"):
            with self.nested(t):
                return Not(self.unary())
        for word, node in (("always", Always), ("eventually", Eventually)):
            if t := self.accept("keyword", word):
                a, b = self.interval()
                with self.nested(t):
                    return node(a, b, self.unary())
        if self.tok.kind == "op" and self.tok.text == "(":
            start = self.i  # a parenthesis opens a formula or an arithmetic expression: try the comparison first
            try:
                return self.comparison()
            except StlError:
                self.i = start
            self.i += 1
            with self.nested(self.toks[start]):
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
        return self.finite(t)

    def finite(self, t: _Tok) -> float:
        """A number's value; one that overflows a double (1e999) is refused, not read as infinity."""
        value = float(t.text)
        if math.isinf(value):
            raise _error(self.text, t.pos, f"number {t.text:.30} is beyond a double's range (at most about 1.8e308; "
                                           "to the end of the run is [a:inf])")
        return value

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
        if t := self.accept("op", "-"):
            if n := self.accept("number"):  # a negative constant is one number
                return Const(-self.finite(n))
            with self.nested(t):
                return Arith("neg", (self.factor(),))
        if t := self.accept("number"):
            return Const(self.finite(t))
        if t := self.accept("name"):
            if "." not in t.text:
                raise _error(self.text, t.pos, f"signal '{t.text}' is not instance.variable (e.g. plant.x)")
            return Signal(t.text)
        if t := self.accept("keyword", "abs"):
            self.expect("op", "(", "'(' after abs")
            with self.nested(t):
                e = self.expr()
            self.expect("op", ")", "')' closing abs(")
            return Arith("abs", (e,))
        if t := self.accept("op", "("):
            start = self.i - 1
            if start in self.failed:  # tried before, from an outer parenthesis's attempt at a comparison
                raise self.failed[start].with_traceback(None)
            try:
                with self.nested(t):
                    e = self.expr()
                self.expect("op", ")", "')'")
            except StlError as err:  # the same tokens fail the same way: nested parentheses stay linear, not quadratic
                self.failed[start] = err
                raise
            return e
        raise self.fail("expected a number, a signal (instance.variable), abs( or '('")



def parse(text: str):
    """The formula's syntax tree; StlError (one line, the position marked) if it does not parse or exceeds a limit."""
    if len(text) > MAX_CHARS:
        raise StlError(f"formula of {len(text)} characters: at most {MAX_CHARS} (a formula is text a person writes; "
                       "split it into several requirements)")
    if not text.strip():
        raise StlError("empty formula")
    try:
        tree = _Parser(text).formula()
    except RecursionError:  # only a caller already deep in its stack: still one line, naming the limit
        raise StlError(f"formula nested too deeply for the room left on Python's stack (at most {MAX_DEPTH} levels "
                       "of parentheses, not, always, eventually, -, abs)") from None
    count = sum(1 for _ in postorder(tree))
    if count > MAX_NODES:
        raise StlError(f"formula of {count} nodes (signals, numbers, operators): at most {MAX_NODES}; split it into "
                       "several requirements")
    return tree



def number_text(v: float) -> str:
    """The shortest text that reads back as the same float ("5" for 5.0, all the digits where :g would drop some)."""
    return _num(v)


def _num(v: float) -> str:
    """The shortest text that reads back as the same float."""
    short = f"{v:g}"
    return short if float(short) == v else repr(v)


def unparse(node) -> str:
    """rtamt's textual form of a tree (fully parenthesized): what --explain shows. Bottom up, without recursion."""
    done: dict[int, str] = {}
    for n in postorder(node):
        parts = [done.pop(id(c)) for c in children(n)]
        if _chained(n):  # a chain (a and b and c) without a parenthesis a level: it reads back however long
            parts[0] = parts[0][1:-1]
        done[id(n)] = _unparse_one(n, parts)
    return done[id(node)]


def _chained(n) -> bool:
    """Whether n continues its left operand's chain of the same operator, and or or: min and max are associative, so
    any tool reads the chain to the same value; arithmetic and implies keep their parentheses (rtamt's grammar may group
    a - b + c or a -> b -> c otherwise than tiltload's)."""
    return isinstance(n, (And, Or)) and type(n.left) is type(n)


def _unparse_one(node, parts: list[str]) -> str:
    """One node's text, its children's texts given."""
    def iv(n) -> str:
        return "" if n.a == 0 and math.isinf(n.b) else f"[{_num(n.a)}:{'inf' if math.isinf(n.b) else _num(n.b)}]"
    if isinstance(node, Signal):
        return node.name
    if isinstance(node, Const):
        return _num(node.value) if node.value >= 0 else f"({_num(node.value)})"
    if isinstance(node, Arith):
        if node.op == "neg":
            return f"-({parts[0]})"
        if node.op == "abs":
            return f"abs({parts[0]})"
        return f"({parts[0]} {node.op} {parts[1]})"
    if isinstance(node, Compare):
        return f"{parts[0]} {node.op} {parts[1]}"
    if isinstance(node, Not):
        return f"not ({parts[0]})"
    if isinstance(node, (And, Or, Implies)):  # implies keeps its parentheses: rtamt's grammar reads a chain of them
        word = {And: "and", Or: "or", Implies: "implies"}[type(node)]  # from the left, tiltload's from the right
        return f"({parts[0]}) {word} ({parts[1]})"
    if isinstance(node, Always):
        return f"always{iv(node)} ({parts[0]})"
    if isinstance(node, Eventually):
        return f"eventually{iv(node)} ({parts[0]})"
    if isinstance(node, Until):
        return f"({parts[0]}) until{iv(node)} ({parts[1]})"
    raise TypeError(node)
