"""In-process evaluation: the numbers the suite reports come from here."""

from __future__ import annotations

import pytest

from manigraph_lab.episode_loop import add_noise, run_episode
from manigraph_lab.evaluate import EvalSpec, evaluate
from manigraph_planner.policies import load_policy
from manigraph_planner.policies.base import Decision, Policy
from manigraph_shared.messages import EpisodeRequest, Scene


class AlwaysTheBottomBlock(Policy):
    """A wrong policy: keeps trying to pull the bottom block out of the stack."""

    name = "bottom"

    def decide(self, scene: Scene) -> Decision | None:
        bottom = min(scene.objects, key=lambda o: o.position.z)
        return Decision(bottom.id, scene.goals[0].id)


def test_expert_is_perfect_and_steps_equal_blocks() -> None:
    summary = evaluate(
        load_policy("expert"), EvalSpec("stack", blocks=7, episodes=5), progress=None
    )
    assert summary["success_rate"] == 1.0 and summary["mean_steps"] == 7.0
    assert summary["infeasible_actions"] == {}


def test_infeasible_actions_fail_honestly_and_are_counted() -> None:
    summary = evaluate(
        AlwaysTheBottomBlock(), EvalSpec("stack", blocks=3, episodes=2), progress=None
    )
    assert summary["success_rate"] == 0.0
    # Refused once per episode: its only option, refused on a world that did not change, is
    # not asked again, and the episode ends out of options (it ran to its step budget,
    # 2 * 3 + 4 refusals, before issue 51).
    assert summary["infeasible_actions"] == summary["refusals"] == {"object_covered": 2}
    assert summary["out_of_options"] == 2


def test_noise_is_seeded_and_reaches_only_the_observation() -> None:
    request = EpisodeRequest(episode_id="n", task="stack", blocks=6, seed=4)
    a = run_episode(load_policy("expert"), request, noise=0.02)
    b = run_episode(load_policy("expert"), request, noise=0.02)
    assert [s.action.object_id for s in a.steps] == [s.action.object_id for s in b.steps]
    assert (
        a.steps[0].scene.objects[0].position
        != run_episode(load_policy("expert"), request).steps[0].scene.objects[0].position
    )


def test_add_noise_moves_every_position() -> None:
    import numpy as np

    from manigraph_sim.geometric.backend import GeometricBackend

    sim = GeometricBackend()
    sim.reset(EpisodeRequest(episode_id="n", task="stack", blocks=2, seed=0), 0.0)
    scene = sim.scene(0.0)
    assert scene is not None
    noisy = add_noise(scene, 0.01, np.random.default_rng(0))
    assert all(o.position != p.position for o, p in zip(noisy.objects, scene.objects, strict=True))
    assert add_noise(scene, 0.0, np.random.default_rng(0)) is scene


@pytest.mark.parametrize("task", ["box-pack", "box-unpack", "pyramid", "multistack"])
def test_every_task_runs_in_process(task: str) -> None:
    spec = EvalSpec(task, blocks=3, stacks=2 if task == "multistack" else 1, episodes=2)
    assert evaluate(load_policy("expert"), spec, progress=None)["success_rate"] == 1.0
