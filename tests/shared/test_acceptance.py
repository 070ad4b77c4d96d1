from manigraph_shared.acceptance import admits, refusal

SIZE = (0.04, 0.04, 0.04)


def test_an_empty_accepts_admits_any_object() -> None:
    assert admits({}, "block_0", SIZE, {})


def test_every_listed_key_must_match() -> None:
    accepts = {"colour": "red", "label": "bolt"}
    assert admits(accepts, "b", SIZE, {"colour": "red", "label": "bolt", "mass": 1.0})
    assert refusal(accepts, "b", SIZE, {"colour": "red", "label": "nut"}) == "label nut is not bolt"
    assert refusal(accepts, "b", SIZE, {"colour": "red"}) == "has no label"


def test_size_matches_within_a_millimetre_on_each_axis() -> None:
    assert admits({"size": [0.03, 0.03, 0.03]}, "b", (0.0305, 0.0295, 0.03), {})
    assert not admits({"size": [0.03, 0.03, 0.03]}, "b", (0.032, 0.03, 0.03), {})


def test_id_names_the_object_itself() -> None:
    assert admits({"id": "part_2"}, "part_2", SIZE, {})
    assert refusal({"id": "part_2"}, "part_3", SIZE, {}) == "id part_3 is not part_2"


def test_numbers_compare_as_numbers_and_never_equal_text() -> None:
    assert admits({"grade": 2}, "b", SIZE, {"grade": 2.0})
    assert not admits({"grade": "2"}, "b", SIZE, {"grade": 2.0})
