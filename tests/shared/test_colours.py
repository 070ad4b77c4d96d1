from manigraph_shared.colours import PALETTE, colour_of, describe, rgb


def test_palette_names_and_hex_are_read_anything_else_is_none() -> None:
    assert rgb("Red") == PALETTE["red"]
    assert rgb("#ff0000") == (1.0, 0.0, 0.0)
    assert rgb("#zz0000") is None
    assert rgb("chartreuse") is None
    assert rgb(3.0) is None


def test_either_spelling_names_the_colour() -> None:
    assert colour_of({"color": "blue"}) == PALETTE["blue"]
    assert colour_of({"label": "bolt"}) is None


def test_describe_reads_like_a_sentence() -> None:
    assert describe({"colour": "red", "mass": 0.25}) == "colour red, mass 0.25"
