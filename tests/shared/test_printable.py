"""Text from a file is printed safely, and text values read apart from numbers (issue 48)."""

from __future__ import annotations

from manigraph_shared.printable import printable, quoted


def test_control_and_direction_characters_are_escaped_and_the_rest_kept() -> None:
    assert printable("red") == "red"
    assert printable("rouge é 😀") == "rouge é 😀"
    assert printable("\x1b[2J\x07") == "\\x1b[2J\\x07"
    assert printable("a\nb\tc\x9b") == "a\\x0ab\\x09c\\x9b"
    assert printable("evil\u202eoops\u2066") == "evil\\u202eoops\\u2066"


def test_quoted_tells_text_from_numbers() -> None:
    assert quoted("2") == '"2"'
    assert quoted(2.0) == "2"
    assert quoted(0.25) == "0.25"
    assert quoted('say "hi"\x1b') == '"say \\"hi\\"\\x1b"'
