"""YAML parser errors in words a mission author can act on.

PyYAML describes what its grammar expected (``expected <block end>, but found '<block mapping
start>'``); these helpers say what to fix instead (the indentation, quotes around a value that
holds ``: ``), give the line and column of a control character, and tell a negated formula read
as a YAML tag from any other tag.
"""

from __future__ import annotations

import re
import unicodedata

import yaml

from stlplan.errors import MissionError

_PLAIN_WORDS = (
    (
        "mapping values are not allowed here",
        "a ': ' (colon and space) inside a plain value starts a mapping; put the value in quotes, "
        'e.g. description: "a: b" (or, when this line is a key of its own, fix its indentation)',
    ),
    (
        "expected <block end>",
        "this line's indentation does not fit the block above it; indent it like the other "
        "keys or items of its block",
    ),
    (
        "could not find expected ':'",
        "a line that is neither 'key: value' nor '- item' (or a quote left open); add the ':' "
        "or close the quote",
    ),
    (
        "found character '\\t' that cannot start any token",
        "a tab character; YAML indents with spaces only",
    ),
)
_FORMULA_TAG = re.compile(r"^!(in|dist|\(|[GFU]\[|p\.|[a-z_]+\.x\[)")


def _plain(problem: str) -> str:
    """``problem`` in plain words, or as PyYAML says it."""
    for jargon, words in _PLAIN_WORDS:
        if jargon in problem:
            return words
    return problem.removeprefix("but ")


def _tag_hint(problem: str) -> str | None:
    """The message for a value read as a YAML tag (None when the problem is another)."""
    match = re.search(r"for the tag '([^']*)'", problem)
    if match is None:
        return None
    tag = match.group(1)
    if _FORMULA_TAG.match(tag):
        return (
            f"a value that starts with '!' (a negated formula, read as the YAML tag '{tag}') "
            'must be quoted: "!..."'
        )
    return f"unknown YAML tag '{tag}'; mission files use no tags (remove it)"


def syntax_error(exc: yaml.MarkedYAMLError, source: str) -> MissionError:
    """A :class:`MissionError` for a YAML syntax error, at its line and column."""
    mark = exc.problem_mark or exc.context_mark
    where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else None
    problem = str(exc.problem or exc)
    hint = _tag_hint(problem)
    if hint is not None:
        return MissionError(f"YAML syntax error: {hint}", source=source, where=where)
    context = ""
    if exc.context and exc.context_mark is not None:
        context = f" ({exc.context} started at line {exc.context_mark.line + 1})"
    return MissionError(
        f"YAML syntax error: {_plain(problem)}{context}", source=source, where=where
    )


def reader_error(exc: yaml.reader.ReaderError, text: str, source: str) -> MissionError:
    """A :class:`MissionError` for a character YAML does not accept, at its line and column."""
    before = text[: exc.position]
    line, column = before.count("\n") + 1, len(before) - (before.rfind("\n") + 1) + 1
    char = chr(exc.character) if isinstance(exc.character, int) else str(exc.character)
    name = unicodedata.name(char, "a control character")
    return MissionError(
        f"the character U+{ord(char):04X} ({name}) is not allowed in a YAML file; remove it",
        source=source,
        where=f"line {line}, column {column}",
    )
