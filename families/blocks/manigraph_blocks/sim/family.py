"""The block family: blocks and covers on a table, open-top boxes, goals a block fills.

Its tasks are ``stack``, ``multistack``, ``pyramid``, the box tasks and every user task file
(``task_file``); its world is the geometric world's (:mod:`.geometric_world`), observed as a
Scene by :mod:`.scene`, and in the physics backend the simulated poses read back by the same
rules (:mod:`.physics`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from manigraph_blocks.sim import boxes, pyramid, stack  # noqa: F401  (register tasks)
from manigraph_blocks.sim.geometric_world import GeometricWorld
from manigraph_blocks.sim.options import BlockOptions, BlockTask
from manigraph_blocks.sim.rules_file import parse_rules_file
from manigraph_blocks.sim.scene import observed_scene
from manigraph_blocks.sim.task_file import FileTask, parse_task_file
from manigraph_shared.errors import SkillError, TaskError
from manigraph_shared.messages import EpisodeRequest, GripperOp, RobotCommand, Scene
from manigraph_sim.family import (
    Evaluation,
    GeometricTaskWorld,
    MakePhysicsWorld,
    PhysicsTaskWorld,
    SimFamily,
)
from manigraph_sim.world_model import Layout


class BlocksFamily(SimFamily):
    """Blocks and covers (``world_model.Layout``).

    **Success Conditions** (:meth:`evaluate`): every required goal holds an object it accepts
    (its category and every key of its ``accepts``), on filled goals; ``wrong_object`` counts
    the goals holding an object of their category that they do not accept.
    """

    name = "blocks"
    help = "blocks and covers: stacks, pyramids, boxes, task files"
    options_type = BlockOptions
    layout_type = Layout
    tasks = ("stack", "multistack", "pyramid", "box-pack", "box-unpack", "box-rearrangement")
    takes_task_files = True
    request_fields = ("blocks", "stacks")

    def geometry_options(self, geometry: str) -> dict[str, Any]:
        """The physics world lays box tasks out with room for the Panda's fingers."""
        super().geometry_options(geometry)
        if geometry == "physics":
            from manigraph_blocks.sim.physics_boxes import PHYSICS_BOXES

            return {"boxes": PHYSICS_BOXES}
        return {}

    def file_task(self, request: EpisodeRequest) -> BlockTask:
        if request.task_file is None:
            raise TaskError("task_file: task 'file' needs the task file's text")
        self.options(request)  # refuses another family's field
        spec = parse_task_file(request.task_file)
        rules = (
            None if request.rules is None else parse_rules_file(request.rules, request.task_file)
        )
        return FileTask(spec, rules)

    def check_task_file(
        self, text: str, source: str, rules: str | None = None, rules_source: str = ""
    ) -> int:
        blocks = parse_task_file(text, source).blocks
        if rules is not None:
            parse_rules_file(rules, text, rules_source or None)
        return blocks

    def evaluate(self, layout: Layout, world: GeometricWorld) -> Evaluation:
        """By the judge's rules where the request brought some (``Layout.judge``): each look
        counts the placements into a goal they refuse that are new since the last."""
        required = frozenset(self.required_goals(layout))
        judge = layout.judge
        judged = judge.goals if judge is not None else None
        filled = required & set(world.occupancy(judged))
        wrong = world.wrong_objects(judged)
        if judge is not None:
            judge.watch(wrong)
        return Evaluation(
            required,
            filled,
            success=filled == required,
            wrong_object_goals=frozenset(wrong),
            rule_violations=judge.violations if judge is not None else 0,
        )

    def geometric_world(self, layout: Layout, goal_tolerance: float) -> BlocksWorld:
        return BlocksWorld(self, layout, goal_tolerance)

    def physics_world(
        self, layout: Layout, make_world: MakePhysicsWorld, goal_tolerance: float
    ) -> PhysicsTaskWorld:
        from manigraph_blocks.sim.physics import PhysicsBlocks

        return PhysicsBlocks(self, layout, make_world(layout.bodies), goal_tolerance)


class BlocksWorld(GeometricWorld, GeometricTaskWorld):
    """The geometric world of a block layout, with a magic gripper: a pick counts a step."""

    def __init__(self, family: BlocksFamily, layout: Layout, goal_tolerance: float) -> None:
        super().__init__(
            layout.bodies,
            layout.goals,
            goal_tolerance,
            containers=layout.containers,
            hide_inside_closed=layout.partially_observable,
        )
        self.family = family
        self.layout = layout

    def execute(self, command: RobotCommand, count_step: Callable[[], None]) -> None:
        if command.op is GripperOp.OPERATE:
            raise SkillError("unsupported", "this task has no fixtures to operate")
        if command.op is GripperOp.PICK:
            # Refused before counting: a pick of nothing is not a step of the episode.
            if command.object_id not in self.bodies:
                raise SkillError("unknown_object", command.object_id)
            count_step()  # every attempted pick counts against the step budget
            self.pick(command.object_id)
        else:
            self.place(command.object_id, np.array(command.position.as_tuple()))

    def scene(self, episode_id: str, stamp: float, sequence: int, ended: bool) -> Scene:
        return observed_scene(self, episode_id, stamp, sequence, ended)

    def evaluate(self) -> Evaluation:
        return self.family.evaluate(self.layout, self)
