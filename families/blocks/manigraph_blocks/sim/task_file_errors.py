"""A task file's problems in words: each names its line where it can be found in the text, and
a key that is not a field suggests the field it was probably meant to be.

``tomllib`` reports no positions for parsed values, so the line is found by reading the text
again: the ``n``-th ``[[objects]]`` header for ``objects.n``, then the line that sets the key
inside that table (or, for a top-level key, before the first table).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from difflib import get_close_matches

from pydantic import BaseModel
from pydantic_core import ErrorDetails

Location = Sequence[int | str]


def describe_errors(
    errors: Iterable[ErrorDetails],
    text: str,
    top: type[BaseModel],
    tables: dict[str, type[BaseModel]],
) -> list[str]:
    """One phrase per validation error: ``line 9: objects.1.postion: Extra inputs are not
    permitted; did you mean position?``. ``top`` is the file's model, ``tables`` the model of
    each array of tables by its key."""
    lines = text.splitlines()
    problems = []
    for error in errors:
        loc = list(error["loc"])
        message = plain(error["type"], error["msg"].removeprefix("Value error, "))
        model = _model_at([*loc, ""], top, tables) if loc else None
        own = re.match(r"^([a-z_]+): ", message)
        if model is not None and own and own.group(1) in model.model_fields:
            # A check of a whole table naming one of its keys: that key's own line.
            loc.append(own.group(1))
            message = message[own.end() :]
        field = ".".join(str(part) for part in loc)
        if error["type"] == "extra_forbidden" and loc and isinstance(loc[-1], str):
            model = _model_at(loc, top, tables)
            if model is not None:
                close = get_close_matches(loc[-1], list(model.model_fields), n=1, cutoff=0.6)
                if close:
                    message += f"; did you mean {close[0]}?"
        if not field:  # whole-file checks name their own fields ("objects.1: red overlaps")
            problems.append(message)
            continue
        line = line_of(lines, loc)
        problems.append((f"line {line}: " if line else "") + f"{field}: {message}")
    return problems


#: Pydantic's words for a kind of error -> plain ones.
PLAIN = {
    "extra_forbidden": "is no key of this table",
    "missing": "is missing; this table needs it",
    "bool_type": "give true or false",
    "string_type": "give text in quotes",
}


def plain(kind: str, message: str) -> str:
    """``message`` in the words of a task file's reader, not of pydantic."""
    if kind in PLAIN:
        return PLAIN[kind]
    for said, meant in (
        ("Input should be a valid ", "give a "),
        ("Input should be ", "must be "),
        ("String should match pattern ", "must match "),
    ):
        if message.startswith(said):
            return meant + message.removeprefix(said)
    return message


def line_of(lines: Sequence[str], loc: Location) -> int | None:
    """The 1-based line that sets the value at ``loc`` (``("objects", 1, "postion")``), or the
    line of its table; None where neither is found."""
    start, end, rest = 0, _first_header(lines, 0), list(loc)
    table_line = None
    if len(loc) >= 2 and isinstance(loc[0], str) and isinstance(loc[1], int):
        header = re.compile(rf"^\s*\[\[\s*{re.escape(loc[0])}\s*\]\]")
        headers = [n for n, line in enumerate(lines) if header.match(line)]
        if loc[1] < len(headers):
            start = headers[loc[1]] + 1
            end = _first_header(lines, start)
            table_line = start
            rest = list(loc[2:])
    key = next((part for part in rest if isinstance(part, str)), None)
    if key is None:
        return table_line
    quoted = re.escape(key)
    patterns = (
        re.compile(rf'^\s*"?{quoted}"?\s*='),  # key = ...
        re.compile(rf'[{{,]\s*"?{quoted}"?\s*='),  # inside an inline table
    )
    for pattern in patterns:
        for n in range(start, end):
            if pattern.search(lines[n]):
                return n + 1
    return table_line


def _first_header(lines: Sequence[str], start: int) -> int:
    """The index of the first table header (``[x]`` or ``[[x]]``) at or after ``start``."""
    for n in range(start, len(lines)):
        if lines[n].lstrip().startswith("["):
            return n
    return len(lines)


def _model_at(
    loc: Location, top: type[BaseModel], tables: dict[str, type[BaseModel]]
) -> type[BaseModel] | None:
    """The model whose field ``loc``'s last part was meant to be."""
    if len(loc) == 1:
        return top
    if len(loc) == 3 and isinstance(loc[0], str) and isinstance(loc[1], int):
        return tables.get(loc[0])
    return None
