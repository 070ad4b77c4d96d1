"""The shipped marker maps agree with the task files they are written for."""

from __future__ import annotations

from pathlib import Path

from manigraph_blocks.sim.task_file import parse_task_file
from manigraph_shared.markers import load_marker_map, sim_marker_map

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_the_colour_sort_map_gives_each_block_the_colour_its_task_file_does() -> None:
    markers = load_marker_map(EXAMPLES / "markers" / "colour-sort.toml")
    task = parse_task_file((EXAMPLES / "tasks" / "colour-sort-camera.toml").read_text())
    assert not task.shuffle  # a camera's blocks keep their colours
    for item in task.objects:
        assert markers.attributes_of(item.id) == item.attributes, item.id
    # The same printed markers as the sim's own map: only the attributes differ.
    plain = [m.model_copy(update={"attributes": {}}) for m in markers.markers]
    assert plain == sim_marker_map().markers
