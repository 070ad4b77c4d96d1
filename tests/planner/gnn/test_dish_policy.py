"""The dishwasher's graph state, four-headed net, its checkpoints and its training."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from manigraph_dishwasher.fixtures import TrayAction
from manigraph_dishwasher.fixtures import rack as rack_in
from manigraph_dishwasher.planner.expert import dishwasher_expert
from manigraph_dishwasher.planner.features import DISH_FEATURE_SPEC, dish_scene_to_graph
from manigraph_dishwasher.planner.gnn_policy import (
    DishwasherGNNPolicy,
    decision_from_heads,
)
from manigraph_dishwasher.planner.net import DishHeads, DishPolicyNet
from manigraph_dishwasher.training.loop import (
    DishTrainConfig,
    dish_loss,
    load_dish_demonstrations,
)
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_planner.gnn.checkpoint import load_checkpoint, save_checkpoint
from manigraph_planner.policies import load_policy
from manigraph_planner.recovery import ProgressMonitor
from manigraph_shared.errors import PolicyError
from manigraph_shared.messages import EpisodeRequest, SkillState, SkillStatus
from manigraph_shared.orientations import UPSIDE_DOWN
from manigraph_sim.geometric.backend import GeometricBackend

CHECKPOINTS = Path(__file__).parents[3] / "checkpoints"


def scene(objects: int = 4):  # type: ignore[no-untyped-def]
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=objects), 0.0)
    return backend.scene(1.0)


def test_the_graph_has_dishes_slots_and_racks_with_their_flags() -> None:
    graph = dish_scene_to_graph(scene(4))
    assert graph.num_objects == 4 and graph.num_goals == 48
    assert graph.rack_ids == ["rack_top", "rack_bottom"]
    assert graph.x.shape == (4 + 48 + 2, DISH_FEATURE_SPEC.num_features)
    names = DISH_FEATURE_SPEC.names
    assert graph.x[:, :6].sum(dim=1).eq(1).all()  # one category each
    assert graph.x[-2:, names.index("open")].tolist() == [0.0, 0.0]
    slots = graph.x[4:52]
    assert slots[:, [names.index(f"orientation-{i}") for i in range(6)]].sum(dim=1).eq(1).all()


def dish_net(seed: int = 0) -> DishPolicyNet:
    torch.manual_seed(seed)
    return DishPolicyNet(DishTrainConfig("sage", hidden_channels=16).model_config())


def test_a_checkpoint_of_an_older_feature_spec_is_refused_naming_the_field(
    tmp_path: Path,
) -> None:
    path = save_checkpoint(tmp_path / "d.pt", dish_net(), training_config={}, data_hash="x")
    assert isinstance(load_checkpoint(path).net, DishPolicyNet)
    payload = torch.load(path, weights_only=True)
    payload["feature_spec"]["names"] = payload["feature_spec"]["names"][:-6]  # no orientations
    payload["feature_spec"]["version"] = "dishwasher-0"
    torch.save(payload, path)
    with pytest.raises(PolicyError, match=r"feature_spec\.names"):
        load_checkpoint(path)


def test_a_block_checkpoint_still_loads_as_the_two_headed_policy() -> None:
    policy = load_policy(str(CHECKPOINTS / "sage.pt"))
    assert not isinstance(policy, DishwasherGNNPolicy)
    assert load_checkpoint(CHECKPOINTS / "sage.pt").info.model.heads == "object-goal"


@pytest.fixture(scope="module")
def demos(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    path = tmp_path_factory.mktemp("dw") / "demos.mcap"
    protocol = DemoProtocol(("dishwasher",), (4,), 2, 0, 4, "top-bottom")
    summary = record_demos(dishwasher_expert("top-bottom"), protocol, path)
    assert summary["trajectories"] == 2
    return load_dish_demonstrations([path])


def test_demonstrations_carry_all_four_targets(demos) -> None:  # type: ignore[no-untyped-def]
    trays = [s.tray for s in demos.samples]
    assert trays.count(2) == 8  # four placements per episode, tray "none"
    assert trays.count(0) == 4 and trays.count(1) == 4  # out and in, each rack, each episode
    assert {s.orientation for s in demos.samples if s.tray == 2} == {1, 2}


def test_training_steps_reduce_the_sum_of_the_four_cross_entropies(demos) -> None:  # type: ignore[no-untyped-def]
    net = dish_net()
    optimiser = torch.optim.Adam(net.parameters(), lr=1e-2)
    losses = []
    for _ in range(30):
        optimiser.zero_grad()
        loss = dish_loss(net, demos.samples)
        loss.backward()
        optimiser.step()
        losses.append(float(loss.detach()))
    assert losses[1] < losses[0]
    assert losses[-1] < 0.85 * losses[0]


def test_the_policy_decodes_a_tray_action_or_a_feasible_placement() -> None:
    policy = DishwasherGNNPolicy(dish_net(1))
    s = scene(4)
    decision = policy.decide(s)
    assert decision is not None
    if TrayAction.of(decision).value == "none":
        dish, slot = s.object(decision.object_id), s.goal(decision.goal_id)
        assert dish.category.value == slot.category.value and not slot.filled
        assert decision.orientation_index is not None
    else:
        assert decision.object_id == decision.goal_id == TrayAction.of(decision).rack_id


def test_a_placement_with_both_racks_in_becomes_the_more_likely_toggle() -> None:
    """Both racks start in: no dish can be placed, so a tray head that says "none" is read
    as its more likely toggle rather than as nothing to do (which ends the episode)."""
    graph = dish_scene_to_graph(scene(4))
    n = graph.x.shape[0]
    heads = DishHeads(torch.zeros(n), torch.zeros(n, 6), torch.tensor([0.5, 1.0, 3.0]))
    decision = decision_from_heads(graph, heads)
    assert decision is not None and TrayAction.of(decision).value == "toggle_bottom"
    heads = DishHeads(torch.zeros(n), torch.zeros(n, 6), torch.tensor([2.0, 1.0, 3.0]))
    decision = decision_from_heads(graph, heads)
    assert decision is not None and decision.object_id == decision.goal_id == "rack_top"


class SlotLikingNet:
    """Stands in for a trained net: every dish equally likely, and the slots whose ids start
    with one of ``liked`` far more likely than the others (as a net trained on one
    preference rates its racks)."""

    architecture = "stub"

    def __init__(self, goal_ids: list[str], liked: tuple[str, ...]) -> None:
        self.goal_ids = goal_ids
        self.liked = liked

    def eval(self) -> SlotLikingNet:
        return self

    def heads_complete(self, x: torch.Tensor) -> DishHeads:
        # Small steps between the nodes: no ties, so the decision is also a ranked pair.
        goals = [
            (5.0 if g.startswith(self.liked) else 0.0) - 0.01 * i
            for i, g in enumerate(self.goal_ids)
        ]
        objects = [-0.01 * i for i in range(len(x) - len(self.goal_ids) - 2)]
        node = torch.tensor(objects + goals + [0.0, 0.0])
        return DishHeads(node, torch.zeros(len(x), 6), torch.tensor([0.0, 0.0, 1.0]))


def _top_rack_out(objects: int = 4):  # type: ignore[no-untyped-def]
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=objects), 0.0)
    backend.world.toggle("rack_top")  # type: ignore[union-attr]
    s = backend.scene(1.0)
    assert s is not None
    return s


def _ranked(s, liked: tuple[str, ...]):  # type: ignore[no-untyped-def]
    goal_ids = dish_scene_to_graph(s).goal_ids
    policy = DishwasherGNNPolicy(SlotLikingNet(goal_ids, liked))  # type: ignore[arg-type]
    ranked = policy.ranked(s)
    assert ranked[0] == policy.decide(s)
    return ranked


def test_ranked_alternatives_start_with_the_decision_and_offer_every_loadable_dish() -> None:
    s = _top_rack_out()
    ranked = _ranked(s, liked=("top_",))
    kinds = [TrayAction.of(d).value == "none" for d in ranked]
    toggles = kinds.index(False)
    # The toggle last: every placement into the open rack comes first (and the bottom rack
    # is not pulled out under the open top one).
    assert kinds[toggles:] == [False]
    assert {d.object_id for d in ranked[toggles:]} == {"rack_top"}
    placements = ranked[:toggles]
    # Each dish once in its likeliest slot, then each again in its other free top-rack
    # slots, round by round: every such pair once.
    first_round = placements[: len(s.objects)]
    assert sorted(d.object_id for d in first_round) == sorted(o.id for o in s.objects)
    assert len({d.pair for d in ranked}) == len(ranked)
    slots = {
        o.id: [g.id for g in s.goals if g.category.value == o.category.value] for o in s.objects
    }
    assert len(placements) == sum(len(v) // 2 for v in slots.values())
    later = placements[len(s.objects) :]
    assert [d.object_id for d in later[: len(s.objects)]] == [d.object_id for d in first_round]
    for d in placements:
        assert s.goal(d.goal_id).fixture == "rack_top" and not s.goal(d.goal_id).filled


def test_a_rack_is_not_left_while_a_dish_may_still_go_into_it() -> None:
    """Bowls on top, plates at the bottom, the top rack out: two bowls that failed to reach
    one slot have it passed over (recovery's escalation); with every bowl liking that slot
    best, the next alternative is a bowl in its next slot, not pushing the rack in."""
    s = _top_rack_out()
    ranked = _ranked(s, liked=("top_bowl", "bottom_plate"))
    best = ranked[0].goal_id
    assert sum(d.goal_id == best for d in ranked) == 2  # both bowls like it best
    monitor = ProgressMonitor()
    for dish in [d for d in ranked if d.goal_id == best][:2]:
        monitor.on_decision(s, dish.pair)
        monitor.on_status(
            SkillStatus(
                decision_id="e:1",
                skill="pick_and_place",
                state=SkillState.FAILED,
                reason="collision",
                stamp=1.0,
            )
        )
    verdict = monitor.verdict(s)
    chosen = next(d for d in ranked if verdict.allows(d.pair))
    assert TrayAction.of(chosen).value == "none" and chosen.goal_id != best


def test_a_dish_standing_in_a_slot_is_never_an_alternative() -> None:
    """Moving a loaded dish is no progress: while another dish kept failing, recovery moved
    loaded plates from slot to slot until the step budget was spent."""
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=4), 0.0)
    world = backend.world
    assert world is not None
    world.toggle("rack_top")
    bowl = next(d for d in world.dishes.values() if d.kind == "bowl")
    slot = next(s for s in world.slots.values() if s.kind == "bowl" and s.rack == "rack_top")
    world.pick(bowl.id)
    world.place(bowl.id, world.slot_position(slot), slot.orientation)
    s = backend.scene(1.0)
    assert s is not None and s.object(bowl.id).filled
    ranked = _ranked(s, liked=("top_",))
    assert bowl.id not in {d.object_id for d in ranked[1:]}
    assert any(d.object_id != bowl.id and TrayAction.of(d).value == "none" for d in ranked)


def test_a_dish_whose_likeliest_slot_is_in_a_rack_pushed_in_waits_for_it() -> None:
    """Bowls on top, plates at the bottom: with the top rack out, a refused bowl's
    alternatives are the other bowls and pushing the top rack in, never a plate into the
    top rack (nothing would take it out again)."""
    s = _top_rack_out()
    ranked = _ranked(s, liked=("top_bowl", "bottom_plate"))
    placements = [d for d in ranked if TrayAction.of(d).value == "none"]
    assert {d.object_id for d in placements} == {o.id for o in s.objects if o.id.startswith("bowl")}
    assert all(d.goal_id.startswith("top_bowl") for d in placements)
    assert {d.object_id for d in ranked if TrayAction.of(d).value != "none"} == {"rack_top"}


def test_a_dish_on_the_counter_waiting_for_its_rack_makes_the_decision_a_toggle() -> None:
    """Bowls on top, plates at the bottom: the bowls stand in the open top rack and a plate
    is still on the counter. The plate waits for the bottom rack, so the decision is to push
    the top rack in, whatever the tray head says: neither the plate into the top rack (it
    would be there for good) nor a loaded bowl moved (the geometric world's failures at 12
    dishes: a plate forgotten, the top rack pulled out again, and a plate put in it or the
    bowls moved about until the step budget was spent)."""
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=4), 0.0)
    world = backend.world
    assert world is not None
    world.toggle("rack_top")
    free = [s for s in world.slots.values() if s.kind == "bowl" and s.rack == "rack_top"]
    bowls = [d for d in world.dishes.values() if d.kind == "bowl"]
    for bowl, slot in zip(bowls, free[: len(bowls)], strict=True):
        world.pick(bowl.id)
        world.place(bowl.id, world.slot_position(slot), slot.orientation)
    s = backend.scene(1.0)
    assert s is not None
    graph = dish_scene_to_graph(s)
    net = SlotLikingNet(graph.goal_ids, ("top_bowl", "bottom_plate"))
    decision = DishwasherGNNPolicy(net).decide(s)  # type: ignore[arg-type]
    assert decision is not None and TrayAction.of(decision) is TrayAction.TOGGLE_TOP
    # With every dish loaded but one that can go where it is wanted, it goes there.
    net = SlotLikingNet(graph.goal_ids, ("top_",))
    decision = DishwasherGNNPolicy(net).decide(s)  # type: ignore[arg-type]
    assert decision is not None and decision.goal_id.startswith("top_plate")


def test_a_dish_waits_for_the_rack_its_kind_stands_in() -> None:
    """A bowl stands in the top rack, another is still on the counter (a physical arm failed
    to load it), and the bottom rack is out. Heads that rate the bottom rack's slots best
    (as the trained ones did in this state, which no demonstration shows) still never send
    the bowl into the bottom rack: it waits for the top one, and the plates go first."""
    backend, left = _one_bowl_loaded_the_bottom_rack_out()
    s = backend.scene(1.0)
    assert s is not None and rack_in(s, "rack_bottom").open and not s.object(left.id).filled
    ranked = _ranked(s, liked=("bottom_",))
    assert ranked[0].object_id.startswith("plate")
    assert left.id not in {d.object_id for d in ranked}


@pytest.mark.parametrize("bottom_out", [False, True])
def test_a_toggle_for_a_waiting_dish_brings_its_rack_nearer(bottom_out: bool) -> None:
    """Every plate stands in the bottom rack and a bowl stands in the top one; the other bowl
    is still to load (a physical placement left it in no slot). Whatever the tray head
    favours, the decision is the toggle towards the top rack: the bottom one pushed in if it
    is out, else the top one pulled out. (With a tray head favouring the bottom rack, the
    decision pulled it out and pushed it in until the step budget was spent.)"""
    backend, left = _one_bowl_loaded_the_bottom_rack_out()
    world = backend.world
    assert world is not None
    for plate in [d for d in world.dishes.values() if d.kind == "plate"]:
        _load(world, plate.id, "rack_bottom")
    if not bottom_out:
        world.toggle("rack_bottom")
    s = backend.scene(1.0)
    assert s is not None and not s.object(left.id).filled
    graph = dish_scene_to_graph(s)
    n = graph.x.shape[0]
    for favoured in range(3):
        tray = torch.zeros(3)
        tray[favoured] = 5.0
        decision = decision_from_heads(graph, DishHeads(torch.zeros(n), torch.zeros(n, 6), tray))
        assert decision is not None
        wanted = TrayAction.TOGGLE_BOTTOM if bottom_out else TrayAction.TOGGLE_TOP
        assert TrayAction.of(decision) is wanted, favoured


def test_a_dish_is_placed_as_its_slot_asks_when_the_orientation_head_says_otherwise() -> None:
    """A bowl a physical turn-over left upright in a slot (no demonstration shows one) had the
    orientation head say "rim-y" for it, and would have gone into the next slot the wrong way
    round again: the decision keeps to the slot's orientation. A plate on another edge of its
    rim stands as its slot asks, so the head's choice is kept."""
    s = _top_rack_out()
    graph = dish_scene_to_graph(s)
    n = graph.x.shape[0]
    orientation = torch.zeros(n, 6)
    orientation[:, 2] = 5.0  # "rim-y" for every dish
    for liked, kind, expected in (("top_bowl", "bowl", UPSIDE_DOWN), ("top_plate", "plate", 2)):
        net = SlotLikingNet(graph.goal_ids, (liked,))
        node = net.heads_complete(graph.x).node
        if kind == "plate":
            orientation[:, 2], orientation[:, 3] = 0.0, 5.0  # "rim-y-flipped": another edge
            expected = 3
        decision = decision_from_heads(
            graph, DishHeads(node, orientation, torch.tensor([0.0, 0.0, 5.0]))
        )
        assert decision is not None and decision.object_id.startswith(kind)
        assert decision.orientation_index == expected


def _one_bowl_loaded_the_bottom_rack_out():  # type: ignore[no-untyped-def]
    """A 4-dish geometric world: one bowl stands in the top rack (pushed in again), the
    bottom rack is out; the world and the other bowl."""
    backend = GeometricBackend()
    backend.reset(EpisodeRequest(episode_id="e", task="dishwasher", objects=4), 0.0)
    world = backend.world
    assert world is not None
    world.toggle("rack_top")
    loaded, left = [d for d in world.dishes.values() if d.kind == "bowl"]
    _load(world, loaded.id, "rack_top")
    world.toggle("rack_top")
    world.toggle("rack_bottom")
    return backend, left


def _load(world, dish_id: str, rack: str) -> None:  # type: ignore[no-untyped-def]
    kind = world.dishes[dish_id].kind
    slot = next(
        s
        for s in world.slots.values()
        if s.kind == kind and s.rack == rack and world.occupant(s.id) is None
    )
    world.pick(dish_id)
    world.place(dish_id, world.slot_position(slot), slot.orientation)


@pytest.mark.skipif(
    not (CHECKPOINTS / "dishwasher-top-bottom-sage.pt").is_file(), reason="not shipped yet"
)
@pytest.mark.parametrize("preference", ["top-bottom", "left-right"])
def test_the_shipped_dishwasher_checkpoints_load_and_act(preference: str) -> None:
    from manigraph_lab.episode_loop import run_episode

    policy = load_policy(str(CHECKPOINTS / f"dishwasher-{preference}-sage.pt"))
    assert isinstance(policy, DishwasherGNNPolicy)
    wins = sum(
        run_episode(
            policy,
            EpisodeRequest(
                episode_id=f"e{seed}",
                task="dishwasher",
                objects=12,
                options={"preference": preference},
                seed=20_000 + seed,
            ),
        ).success
        for seed in range(5)
    )
    assert wins >= 4
    with torch.no_grad():
        heads = policy.net.heads_complete(dish_scene_to_graph(scene(2)).x)
    assert torch.isfinite(heads.tray).all() and heads.orientation.shape == (2 + 48 + 2, 6)


def test_dropping_dishes_keeps_the_demonstrated_decision(demos) -> None:  # type: ignore[no-untyped-def]
    import random

    from manigraph_dishwasher.training.augment import drop_dishes

    rng = random.Random(0)
    shrunk = 0
    for sample in demos.samples:
        for _ in range(5):
            copy = drop_dishes(sample, rng)
            shrunk += copy.num_objects < sample.num_objects
            assert copy.x.shape[0] == copy.num_objects + sample.num_goals + 2
            if sample.tray == 2:  # a placement: the same dish, the same slot
                assert torch.equal(copy.x[copy.object_index], sample.x[sample.object_index])
                assert copy.goal_index == sample.goal_index
            dishes = copy.x[: copy.num_objects]
            for kind in (0, 1):
                before = (
                    (sample.x[: sample.num_objects, kind] == 1)
                    & (sample.x[:, 9][: sample.num_objects] == 0)
                ).any()
                after = ((dishes[:, kind] == 1) & (dishes[:, 9] == 0)).any()
                rack_in = (
                    sample.tray < 2
                    and sample.x[sample.num_objects + sample.num_goals + sample.tray, 10] == 0
                )
                if rack_in and before:
                    assert after  # a rack pulled out still has a dish of each kind to load
    assert shrunk > len(demos.samples)


@pytest.mark.parametrize("favoured", [0, 1, 2])
def test_a_rack_is_never_pulled_out_under_the_other_one_pulled_out(favoured: int) -> None:
    """With the top rack out, pulling the bottom one out loads neither (the bottom rack only
    while the top one is in): whatever the tray head favours, that toggle is never the
    decision nor an alternative (a policy reading racks where a physical world has them once
    did it, and loaded bowls into the bottom rack)."""
    s = _top_rack_out(4)
    graph = dish_scene_to_graph(s)
    n = graph.x.shape[0]
    tray = torch.zeros(3)
    tray[favoured] = 5.0
    heads = DishHeads(torch.zeros(n), torch.zeros(n, 6), tray)
    decision = decision_from_heads(graph, heads)
    assert decision is not None and TrayAction.of(decision) is not TrayAction.TOGGLE_BOTTOM
    goal_ids = graph.goal_ids
    policy = DishwasherGNNPolicy(SlotLikingNet(goal_ids, ("top_bowl",)))  # type: ignore[arg-type]
    assert all(TrayAction.of(d) is not TrayAction.TOGGLE_BOTTOM for d in policy.ranked(s))
    assert any(TrayAction.of(d) is TrayAction.TOGGLE_TOP for d in policy.ranked(s))
