"""Marker maps: parsing with named errors, face geometry, the sim's committed map."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from manigraph_shared.errors import ConfigError
from manigraph_shared.markers import (
    MarkerSpec,
    load_marker_map,
    marker_in_object,
    parse_marker_map,
    sim_marker_map,
)

ROOT = Path(__file__).resolve().parents[2]

ONE = """
dictionary = "DICT_4X4_50"
[[markers]]
id = 3
object = "block_0"
category = "block"
size = 0.03
face = "+x"
"""


def test_the_committed_sim_map_is_the_generated_one() -> None:
    assert load_marker_map(ROOT / "examples" / "markers" / "sim.toml") == sim_marker_map()


def test_a_map_round_trips_through_toml() -> None:
    parsed = parse_marker_map(ONE)
    assert parse_marker_map(parsed.to_toml()) == parsed
    assert parsed.by_id()[3].face == "+x"


@pytest.mark.parametrize(
    ("text", "field"),
    [
        (ONE.replace("+x", "front"), "markers.0.face"),
        (ONE.replace("0.03", "-1"), "markers.0.size"),
        (ONE.replace("DICT_4X4_50", "DICT_9X9_7"), "dictionary"),
        (ONE.replace("id = 3", "id = 50"), "markers"),
        (ONE + ONE.split("\n", 2)[2], "markers"),
        ("dictionary = ", "marker map"),
    ],
)
def test_a_bad_map_names_the_field(text: str, field: str) -> None:
    with pytest.raises(ConfigError) as error:
        parse_marker_map(text)
    assert field in str(error.value)


def test_an_object_without_a_marker_is_named() -> None:
    parsed = parse_marker_map(ONE)
    parsed.check_objects([("block_0", "block")])
    with pytest.raises(ConfigError, match="block_1"):
        parsed.check_objects([("block_0", "block"), ("block_1", "block")])
    with pytest.raises(ConfigError, match=r"block_0.*cover"):
        parsed.check_objects([("block_0", "cover")])


def test_a_missing_file_is_named(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"nope\.toml"):
        load_marker_map(tmp_path / "nope.toml")


def test_face_frames_point_out_of_the_object() -> None:
    size = np.array([0.04, 0.06, 0.02])
    for face, normal, depth in [("top", 2, 0.01), ("-y", 1, -0.03), ("+x", 0, 0.02)]:
        spec = MarkerSpec(id=0, object="o", category="block", size=0.01, face=face)
        pose = marker_in_object(spec, size)
        assert np.isclose(pose[normal, 3], depth)
        assert np.isclose(abs(pose[normal, 2]), 1.0)  # the marker's z is the face normal
        assert np.isclose(np.linalg.det(pose[:3, :3]), 1.0)


def test_markers_give_their_object_attributes_that_survive_toml() -> None:
    text = """
[[markers]]
id = 0
object = "block_0"
category = "block"
size = 0.034
attributes = { colour = "red", grade = 2 }

[[markers]]
id = 1
object = "block_0"
category = "block"
size = 0.034
face = "+x"
"""
    markers = parse_marker_map(text)
    assert markers.attributes_of("block_0") == {"colour": "red", "grade": 2.0}
    assert parse_marker_map(markers.to_toml()).attributes_of("block_0") == {
        "colour": "red",
        "grade": 2.0,
    }


def test_markers_of_one_object_that_disagree_on_an_attribute_are_refused() -> None:
    text = """
[[markers]]
id = 0
object = "block_0"
category = "block"
size = 0.034
attributes = { colour = "red" }

[[markers]]
id = 1
object = "block_0"
category = "block"
size = 0.034
attributes = { colour = "blue" }
"""
    with pytest.raises(ConfigError, match="two values of colour"):
        parse_marker_map(text)
