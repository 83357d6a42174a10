"""Text to formula tree (lark) and formula tree back to text."""

from __future__ import annotations

import re
from functools import cache
from importlib import resources

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, VisitError

from stlplan.errors import FormulaError, unusual_characters
from stlplan.formula.tree import (
    Always,
    And,
    AtLeast,
    Comparison,
    Count,
    Distance,
    Eventually,
    Formula,
    InRegion,
    Interval,
    Linear,
    Not,
    Or,
    Predicate,
    Term,
    Until,
    Visits,
    Who,
    negate,
)

RESERVED = frozenset(
    {"G", "F", "U", "in", "dist", "count", "visits", "x"}
    | {"always", "eventually", "until", "not", "and", "or", "implies"}
)
MAX_NESTING = 100
"""Levels of nested operators a formula may have; deeper trees would exhaust Python's stack."""


@cache
def _lark() -> Lark:
    text = resources.files("stlplan.formula").joinpath("grammar.lark").read_text()
    return Lark(text, parser="lalr", lexer="contextual", propagate_positions=False)


@v_args(inline=True)
class _ToTree(Transformer):  # type: ignore[type-arg]
    """Calls the tree constructors bottom-up; ``!`` is pushed down to atoms."""

    def implication(self, premise: Formula, _op: Token, conclusion: Formula) -> Formula:
        # a -> b  =  !a | b, with the negation pushed down to the atoms
        return Or((negate(premise), conclusion))

    def disjunction(self, *items: Formula | Token) -> Formula:
        return Or(tuple(i for i in items if not isinstance(i, Token)))

    def conjunction(self, *items: Formula | Token) -> Formula:
        return And(tuple(i for i in items if not isinstance(i, Token)))

    def until(self, left: Formula, op: Token, interval: Interval, right: Formula) -> Formula:
        return Until(interval, left, right, strict=op.type in ("STRICT_UNTIL", "UNTIL_WORD"))

    def negation(self, _op: Token, child: Formula) -> Formula:
        return negate(child)

    def always(self, _op: Token, interval: Interval, child: Formula) -> Formula:
        return Always(interval, child)

    def eventually(self, _op: Token, interval: Interval, child: Formula) -> Formula:
        return Eventually(interval, child)

    def interval(self, lo: Token, hi: Token) -> Interval:
        return Interval(int(lo), int(hi))

    def in_region(self, role: Token, region: Token) -> Formula:
        return InRegion(_role(role), str(region))

    def distance(self, left: Token, right: Token, op: Token, radius: float) -> Formula:
        if radius < 0:
            raise FormulaError(f"distance bound must be >= 0, found {_num(radius)}")
        return Distance(_role(left), _role(right), _cmp(op), radius)

    def count(self, region: Token, *rest: object) -> Formula:
        who, op, n = _counted(rest)
        return Count(str(region), who, op, n)

    def visits(self, interval: Interval, region: Token, *rest: object) -> Formula:
        who, op, n = _counted(rest)
        return Visits(interval, str(region), who, op, n)

    def every_of(self, *items: Token) -> Who:
        return Who(_capabilities(items))

    def any_of(self, *items: Token) -> Who:
        return Who(_capabilities(items), any_of=True)

    def linear(self, terms: tuple[Term, ...], op: Token, bound: float) -> Formula:
        return Linear(terms, _cmp(op), bound)

    def linear_sum(self, *items: Token | Term) -> tuple[Term, ...]:
        signs: list[str] = ["+"] if isinstance(items[0], Term) else []
        terms: list[Term] = []
        for item in items:
            if isinstance(item, Term):
                negative = signs[len(terms)] == "-"
                terms.append(Term(-item.coef, item.role, item.component) if negative else item)
            else:
                signs.append(str(item))
        return tuple(terms)

    def term(self, *items: Token) -> Term:
        coef = float(items[0]) if len(items) == 3 else 1.0
        return Term(coef, _role(items[-2]), int(items[-1]))

    def number(self, *items: Token) -> float:
        value = float(items[-1])
        return -value if len(items) == 2 and items[0] == "-" else value


def _role(token: object) -> str:
    name = str(token)
    if name in RESERVED:
        raise FormulaError(f"'{name}' is a reserved word and cannot name a role")
    return name


def _capabilities(items: tuple[Token, ...]) -> tuple[str, ...]:
    return tuple(dict.fromkeys(str(t) for t in items if t.type == "NAME"))


def _counted(rest: tuple[object, ...]) -> tuple[Who, Comparison, int]:
    """The selector (every agent when absent), comparison and whole-number bound of a count."""
    who = rest[0] if isinstance(rest[0], Who) else Who()
    op, bound = rest[-2], rest[-1]
    assert isinstance(op, Token) and isinstance(bound, float)
    if bound < 0 or not float(bound).is_integer():
        raise FormulaError(
            f"a count is compared with a whole number of agents or visits, found {_num(bound)}; "
            "expected 0, 1, 2, ..."
        )
    return who, _cmp(op), int(bound)


def _cmp(token: Token) -> Comparison:  # the grammar allows only '<=' and '>='
    return "<=" if str(token) == "<=" else ">="


def parse(text: str, *, source: str | None = None, where: str | None = None) -> Formula:
    """Parse ``text`` into a formula tree.

    Raises
    ------
    FormulaError
        With the line and column of a syntax error and a caret under it.
    """
    try:
        tree = _lark().parse(text)
        _check_nesting(tree)
        return _ToTree().transform(tree)  # type: ignore[no-any-return]
    except VisitError as exc:
        if isinstance(exc.orig_exc, FormulaError):
            raise FormulaError(exc.orig_exc.message, source=source, where=where) from None
        raise
    except FormulaError as exc:
        raise FormulaError(exc.message, source=source, where=where) from None
    except UnexpectedInput as exc:
        raise FormulaError(_syntax_message(text, exc), source=source, where=where) from None


def _check_nesting(tree: Tree[Token]) -> None:
    """Reject parse trees deeper than ``MAX_NESTING`` (walked without recursion)."""
    stack = [(tree, 0)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_NESTING:
            token = next(node.scan_values(lambda v: isinstance(v, Token)), None)
            at = f" at line {token.line}, column {token.column}" if token is not None else ""
            raise FormulaError(
                f"formula nests operators more than {MAX_NESTING} levels deep{at}; expected at "
                f"most {MAX_NESTING} levels (split it or remove redundant operators)"
            )
        stack.extend((child, depth + 1) for child in node.children if isinstance(child, Tree))


def _syntax_message(text: str, exc: UnexpectedInput) -> str:
    line, column = max(exc.line, 1), max(exc.column, 1)
    token = getattr(exc, "token", None)
    if isinstance(exc, UnexpectedEOF) or (token is not None and token.type == "$END"):
        lines = text.splitlines() or [""]
        line, column = len(lines), len(lines[-1]) + 1
        found = "end of formula"
    elif isinstance(exc, UnexpectedCharacters):
        char = text[exc.pos_in_stream or 0]
        found = f"character {char!r}"
        if odd := unusual_characters(char):
            found += f" ({odd.removesuffix(' at position 1')}; formulas are written in ASCII)"
    else:
        found = repr(str(token))
    expected = sorted(getattr(exc, "expected", None) or getattr(exc, "allowed", None) or [])
    hint = f"; expected one of: {', '.join(_pretty(e) for e in expected)}" if expected else ""
    source_line = (text.splitlines() or [""])[line - 1] if text else ""
    caret = " " * (column - 1) + "^"
    spelling = _spelling_hint(source_line, column - 1)
    return (
        f"formula syntax error at line {line}, column {column}: unexpected {found}{hint}\n"
        f"  {source_line}\n  {caret}{spelling}"
    )


_PAST = "stlplan has no past-time operators; state the requirement forward with G, F, U or U*"
_SPELLINGS = {
    "next": "stlplan has no 'next': write F[1,1] phi",
    "X": "if X means 'next': stlplan has none; write F[1,1] phi",
    "prev": _PAST,
    "previously": _PAST,
    "historically": _PAST,
    "once": _PAST,
    "since": _PAST,
    "rise": "stlplan has no 'rise': write !phi & F[1,1] phi",
    "fall": "stlplan has no 'fall': write phi & F[1,1] !phi",
    "xor": "stlplan has no 'xor': write (a & !b) | (!a & b)",
    "iff": "stlplan has no 'iff': write (a -> b) & (b -> a)",
    "<->": "stlplan has no '<->': write (a -> b) & (b -> a)",
    "==": "comparisons are '<=' or '>=' (write both for an equality)",
    "<": "comparisons are '<=' or '>=' (a strict '<' has the same robustness as '<=')",
    ">": "comparisons are '<=' or '>=' (a strict '>' has the same robustness as '>=')",
}


def _spelling_hint(line: str, at: int) -> str:
    """A line naming stlplan's spelling of an operator other STL tools write, found at (or just
    before) column ``at`` of ``line``; empty when there is none."""
    words = re.findall(r"[A-Za-z_]+|<->|==|<=?|>=?", line)
    near = [m for m in re.finditer(r"[A-Za-z_]+|<->|==|<=?|>=?", line) if m.start() <= at]
    for match in reversed(near[-2:]):
        hint = _SPELLINGS.get(match.group())
        if hint is not None:
            return f"\n  {hint}"
    if "always" in words or "eventually" in words:
        return "\n  intervals are required: always[a,b], eventually[a,b] (or [a:b])"
    return ""


_TERMINAL_TEXT = {
    "LPAR": "'('",
    "RPAR": "')'",
    "COMMA": "','",
    "LSQB": "'['",
    "RSQB": "']'",
    "NOT": "'!'",
    "ALWAYS": "'G'",
    "EVENTUALLY": "'F'",
    "UNTIL": "'U'",
    "STRICT_UNTIL": "'U*'",
    "IMPLIES": "'->'",
    "OR": "'|'",
    "AND": "'&'",
    "COLON": "':'",
    "IMPLIES_WORD": "'implies'",
    "OR_WORD": "'or'",
    "AND_WORD": "'and'",
    "NOT_WORD": "'not'",
    "ALWAYS_WORD": "'always'",
    "EVENTUALLY_WORD": "'eventually'",
    "UNTIL_WORD": "'until'",
    "AMPERSAND": "'&'",
    "VBAR": "'|'",
    "STAR": "'*'",
    "DOT": "'.'",
    "SIGN": "'+' or '-'",
    "COMPARISON": "'<=' or '>='",
    "UNSIGNED": "a number",
    "INT": "an integer",
    "NAME": "a name",
    "IN": "'in'",
    "DIST": "'dist'",
    "COUNT": "'count'",
    "VISITS": "'visits'",
    "X": "'x'",
    "$END": "end of formula",
}


def _pretty(terminal: str) -> str:
    return _TERMINAL_TEXT.get(terminal, terminal)


def _num(value: float) -> str:
    return (
        str(int(value)) if float(value).is_integer() and abs(value) < 1e15 else repr(float(value))
    )


def _terms_text(terms: tuple[Term, ...]) -> str:
    parts = []
    for i, t in enumerate(terms):
        sign = "-" if t.coef < 0 else "+"
        mag = abs(t.coef)
        body = (
            f"{t.role}.x[{t.component}]" if mag == 1 else f"{_num(mag)}*{t.role}.x[{t.component}]"
        )
        parts.append(("-" if sign == "-" else "") + body if i == 0 else f" {sign} {body}")
    return "".join(parts)


def _wrap(formula: Formula) -> str:
    text = to_text(formula)
    return f"({text})" if isinstance(formula, (And, Or, Until)) else text


def to_text(formula: Formula) -> str:
    """Print ``formula`` in the grammar's syntax; ``parse(to_text(f)) == f`` for parser trees."""
    if isinstance(formula, InRegion):
        return f"in({formula.role}, {formula.region})"
    if isinstance(formula, Distance):
        return f"dist({formula.left}, {formula.right}) {formula.op} {_num(formula.radius)}"
    if isinstance(formula, Linear):
        return f"{_terms_text(formula.terms)} {formula.op} {_num(formula.bound)}"
    if isinstance(formula, Predicate):
        return f"{_terms_text(formula.terms)} >= {_num(formula.bound)}"
    if isinstance(formula, Count):
        return f"count({_counted_text(formula.region, formula.who)}) {formula.op} {formula.n}"
    if isinstance(formula, Visits):
        i = formula.interval
        counted = _counted_text(formula.region, formula.who)
        return f"visits[{i.lo},{i.hi}]({counted}) {formula.op} {formula.n}"
    if isinstance(formula, Not):
        return f"!{_wrap_atom(formula.atom)}"
    if isinstance(formula, And):
        return " & ".join(_wrap(c) for c in formula.children)
    if isinstance(formula, Or):
        return " | ".join(_wrap(c) for c in formula.children)
    if isinstance(formula, Always):
        return f"G[{formula.interval.lo},{formula.interval.hi}] {_wrap(formula.child)}"
    if isinstance(formula, Eventually):
        return f"F[{formula.interval.lo},{formula.interval.hi}] {_wrap(formula.child)}"
    if isinstance(formula, AtLeast):  # a lowered count: read, not parsed
        return f"at least {formula.n} of ({'; '.join(to_text(o) for o in formula.options)})"
    i, op = formula.interval, "U*" if formula.strict else "U"
    return f"{_wrap(formula.left)} {op}[{i.lo},{i.hi}] {_wrap(formula.right)}"


def _counted_text(region: str, who: Who) -> str:
    return f"{region}, {who.text()}" if who.capabilities else region


def _wrap_atom(atom: Formula) -> str:
    text = to_text(atom)
    return text if isinstance(atom, InRegion) else f"({text})"
