"""Text from a file, made safe to print: a message that quotes what a user's file holds never
sends the terminal a control sequence.

A task file may hold any text in a value (``colour = "\\u001b[2J"``) or a quoted key; echoed
raw in an error, an ANSI escape clears the screen, recolours every later line or rewrites the
title, and a bidirectional override makes the message read differently from what it says.
:func:`printable` writes each such character as its escape (``\\x1b``, ``\\u202e``), which is
also how the file would spell it; :func:`quoted` gives a value as a goal's ``accepts`` wrote
it, so ``"2"`` (text) and ``2`` (a number) read differently.
"""

from __future__ import annotations


def printable(text: str) -> str:
    """``text`` with every character Python does not print (controls: C0, DEL, C1; line and
    paragraph separators; format characters, bidirectional overrides among them; spaces other
    than " ") written as its escape; other text, accents and emoji included, as it is. Tabs
    and newlines are escaped too: a message is one line."""
    if text.isprintable():
        return text  # the common case, in one pass in C
    return "".join(_escape(c) for c in text)


def quoted(value: object) -> str:
    """A value as it reads in a task file: text in double quotes (made :func:`printable`), a
    number as ``:g`` writes it, anything else by ``str``."""
    if isinstance(value, str):
        return '"' + printable(value).replace('"', '\\"') + '"'
    if isinstance(value, int | float) and not isinstance(value, bool):
        return f"{value:g}"
    return printable(str(value))


def _escape(char: str) -> str:
    if char.isprintable():
        return char
    code = ord(char)
    if code <= 0xFF:
        return f"\\x{code:02x}"
    if code <= 0xFFFF:
        return f"\\u{code:04x}"
    return f"\\U{code:08x}"
