"""The box tasks' geometry is a parameter: the default is the demonstrations' layout, the
physics world passes its own (wider grid, bigger boxes) and the geometric world can too."""

from __future__ import annotations

import numpy as np
import pytest

from manigraph_blocks.sim.box_geometry import BoxGeometry
from manigraph_blocks.sim.options import BlockOptions
from manigraph_blocks.sim.physics_boxes import PHYSICS_BOXES
from manigraph_shared.errors import TaskError
from manigraph_shared.messages import EpisodeRequest
from manigraph_sim.backends import create_backend
from manigraph_sim.tasks import get_task


def test_the_default_geometry_is_the_demonstrations() -> None:
    layout = get_task("box-unpack", BlockOptions(blocks=4)).layout(np.random.default_rng(0))
    (box,) = layout.containers
    assert np.allclose(box.inner, 0.14) and box.height == 0.06
    centres = np.array([b.position[:2] for b in layout.bodies if b.category == "block"])
    offsets = np.round((centres - box.centre) / 0.045).astype(int).tolist()
    assert offsets == [[0, 0], [-1, 0], [0, -1], [0, 1]]  # centre first, 4.5 cm apart
    cover = layout.bodies[-1]
    assert np.allclose(cover.size, [0.16, 0.16, 0.01]) and np.isclose(cover.position[2], 0.065)
    explicit = get_task("box-unpack", BlockOptions(blocks=4, boxes=BoxGeometry()))
    again = explicit.layout(np.random.default_rng(0))
    assert [b.position.tolist() for b in again.bodies] == [
        b.position.tolist() for b in layout.bodies
    ]


def test_the_geometric_world_can_lay_out_the_physical_boxes() -> None:
    request = EpisodeRequest(episode_id="e", task="box-pack", blocks=3, seed=2)
    backend = create_backend("geometric", box_geometry="physics")
    backend.reset(request, 1.0)
    scene = backend.scene(1.0)
    assert scene is not None
    assert np.isclose(scene.object("cover_0").size.x, PHYSICS_BOXES.cover_size[0])
    assert np.isclose(scene.goal("lid_goal_0").position.z, PHYSICS_BOXES.lid_height)


def test_box_geometry_is_validated_by_field() -> None:
    with pytest.raises(TaskError, match=r"box_geometry\.pitch"):
        BoxGeometry(pitch=(0.1, 0.045))
    with pytest.raises(TaskError, match=r"box_geometry\.site_x"):
        BoxGeometry(site_x=(0.7, 0.3))
    with pytest.raises(TaskError, match=r"box_geometry\.max_blocks"):
        BoxGeometry(max_blocks=10)


@pytest.mark.parametrize("seed", [1001, 1036])
def test_the_physical_box_rearrangement_lays_out_seeds_that_once_found_no_sites(
    seed: int,
) -> None:
    """Four cover footprints fit in the physics site area about one draw in 10^5; these
    seeds found none in the sampler's first 64 batches and failed at reset."""
    from manigraph_sim.tasks.from_request import episode_layout

    request = EpisodeRequest(
        episode_id=f"rearrange-{seed}", task="box-rearrangement", blocks=4, seed=seed
    )
    layout = episode_layout(request, "physics").layout
    side = float(PHYSICS_BOXES.cover_size[0])
    sites = [c.centre[:2] for c in layout.containers]
    sites += [g.position[:2] for g in layout.goals if g.id.startswith("storage_")]
    assert len(sites) == 4
    for i, a in enumerate(sites):
        for b in sites[i + 1 :]:
            assert np.abs(a - b).max() >= side
