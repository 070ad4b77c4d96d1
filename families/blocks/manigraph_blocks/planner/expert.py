"""The hand-designed expert of the paper: highest movable block to the lowest free goal."""

from __future__ import annotations

from manigraph_planner.policies.base import Decision, Policy, register_policy
from manigraph_planner.policies.matching import GoalMatching
from manigraph_planner.scene_geometry import SceneGeometry
from manigraph_shared.messages import GoalCategory, ObjectCategory, Scene, SceneGoal, SceneObject


def _lowest(goals: list[SceneGoal]) -> SceneGoal:
    return min(goals, key=lambda g: (round(g.position.z, 4), g.id))


def _highest(objects: list[SceneObject]) -> SceneObject:
    return min(objects, key=lambda o: (-round(o.position.z, 4), o.id))


@register_policy("expert")
class ExpertPolicy(Policy):
    """What the demonstrations show, in three rules (ties go to the smaller id):

    1. Blocks: move the highest movable block that is in no goal to the lowest free block goal
       that nothing lies over.
    2. Opening: if a cover lies over a free block goal or over a block still to move, move the
       highest such cover to the lowest free cover goal (a storage place on the table).
    3. Closing: once no block can be moved, move the cover in the lowest cover goal to the
       highest free cover goal (back onto its box).

    It sees only what the Scene shows: with everything still hidden in closed boxes it has
    nothing to do (box rearrangement is a test of the learned policy, not of the expert).

    Where a goal says what it ``accepts`` (a task file's attributes, ids or sizes), rule 1 is
    :mod:`~manigraph_planner.policies.matching`'s: objects matched to the goals that accept
    them, the lowest goal that can be filled first, objects in a goal that refuses them moved
    out; rules 2 and 3 stay. Without any ``accepts`` its decisions are exactly the three
    rules above (the shipped checkpoints' demonstrations and the golden logs).
    """

    def ranked(self, scene: Scene) -> list[Decision]:
        """Its decision first, then every other movable block (highest first) to every open
        block goal (lowest first): what a planner tries when the first made no progress."""
        geometry = SceneGeometry(scene)
        if _accepting(scene):
            moves = GoalMatching(scene, geometry).ranked_moves()
            cover = None if moves else self._decide_accepting(scene, geometry)
            return moves if moves else [] if cover is None else [cover]
        first = self._decide(scene, geometry)
        if first is None:
            return []
        objects = [o for o in scene.objects if o.visible]
        goals = [g for g in scene.goals if g.visible and g.category is GoalCategory.BLOCK]
        movable = [
            o
            for o in objects
            if o.category is ObjectCategory.BLOCK and not o.filled and not geometry.is_covered(o)
        ]
        open_goals = [g for g in goals if not g.filled and not geometry.is_blocked(g)]
        movable.sort(key=lambda o: (-round(o.position.z, 4), o.id))
        open_goals.sort(key=lambda g: (round(g.position.z, 4), g.id))
        others = [
            Decision(o.id, g.id) for o in movable for g in open_goals if (o.id, g.id) != first.pair
        ]
        return [first, *others]

    def decide(self, scene: Scene) -> Decision | None:
        if _accepting(scene):
            return self._decide_accepting(scene, SceneGeometry(scene))
        return self._decide(scene, SceneGeometry(scene))

    def _decide_accepting(self, scene: Scene, geometry: SceneGeometry) -> Decision | None:
        matching = GoalMatching(scene, geometry)
        move = matching.first_move()
        if move is not None:
            return move
        return _cover_moves(
            matching.objects, matching.goals, geometry, matching.open_goals(), matching.to_place()
        )

    def _decide(self, scene: Scene, geometry: SceneGeometry) -> Decision | None:
        objects = [o for o in scene.objects if o.visible]
        goals = [g for g in scene.goals if g.visible]
        free_block_goals = [g for g in goals if g.category is GoalCategory.BLOCK and not g.filled]
        blocks_to_move = [o for o in objects if o.category is ObjectCategory.BLOCK and not o.filled]

        open_goals = [g for g in free_block_goals if not geometry.is_blocked(g)]
        movable = [o for o in blocks_to_move if not geometry.is_covered(o)]
        if open_goals and movable:
            return Decision(_highest(movable).id, _lowest(open_goals).id)
        return _cover_moves(objects, goals, geometry, free_block_goals, blocks_to_move)


def _accepting(scene: Scene) -> bool:
    """Some goal says what it accepts: the matching rules decide the blocks' moves."""
    return any(g.accepts for g in scene.goals if g.visible)


def _cover_moves(
    objects: list[SceneObject],
    goals: list[SceneGoal],
    geometry: SceneGeometry,
    free_block_goals: list[SceneGoal],
    blocks_to_move: list[SceneObject],
) -> Decision | None:
    """Rules 2 and 3: a cover out of the way of the blocks' work, or back onto its box."""
    free_cover_goals = [g for g in goals if g.category is GoalCategory.COVER and not g.filled]
    if free_block_goals and blocks_to_move:
        in_the_way = {
            o.id: o
            for goal in free_block_goals
            for o in geometry.objects_above_goal(goal)
            if o.category is ObjectCategory.COVER
        }
        for block in blocks_to_move:
            for o in geometry.objects_over(block):
                if o.category is ObjectCategory.COVER:
                    in_the_way[o.id] = o
        covers = [o for o in in_the_way.values() if not geometry.is_covered(o)]
        if covers and free_cover_goals:
            return Decision(_highest(covers).id, _lowest(free_cover_goals).id)

    covers_in_goals = [
        o
        for o in objects
        if o.category is ObjectCategory.COVER and o.filled and not geometry.is_covered(o)
    ]
    if covers_in_goals and free_cover_goals:
        cover = min(covers_in_goals, key=lambda o: (round(o.position.z, 4), o.id))
        target = max(free_cover_goals, key=lambda g: (round(g.position.z, 4), g.id))
        if target.position.z > cover.position.z + 1e-3:
            return Decision(cover.id, target.id)
    return None
