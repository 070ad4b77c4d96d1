"""What a click on the demonstration page asks for, and the ``Action`` it becomes: checked
against the scene before it is sent (:func:`action_for`), refused with a message for the page
(:class:`ClickRefused`) where the scene does not allow it. Whether the robot is free to take
it is the session's business (:class:`~manigraph_tools.click_page.session.DemoSession`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from manigraph_shared.errors import ManigraphError
from manigraph_shared.ids import derived_id
from manigraph_shared.messages import Action, Scene
from manigraph_shared.orientations import NUM_ORIENTATIONS, ORIENTATION_NAMES, nearest_orientation

#: ``Action.policy`` of every decision a person makes through the page.
POLICY = "human"
#: ``Action.policy`` of a decision a policy proposed and the person accepted
#: (``demo-ui --propose``; docs/demo-ui.md).
ACCEPTED = "human:accepted"
#: ``Action.policy`` of a decision the person clicked instead of the one proposed.
CORRECTED = "human:corrected"


class ClickRefused(ManigraphError):
    """A click the page must not turn into an action; the text is shown to the person."""


@dataclass(frozen=True)
class Click:
    """What the page asks for: an object to a goal (in an orientation), or a family action
    (``family_action``, such as ``toggle``) on fixture ``object_id``."""

    object_id: str | None = None
    goal_id: str | None = None
    orientation_index: int | None = None
    family_action: str | None = None


def action_for(
    click: Click,
    scene: Scene,
    episode_id: str,
    step: int,
    clock: Callable[[], float],
    policy: str = POLICY,
) -> Action:
    """The ``Action`` for ``click`` on ``scene`` as step ``step`` of ``episode_id``, stamped by
    ``clock`` and named ``policy``; :class:`ClickRefused` saying why not where the scene does
    not allow it (an id it does not have or hides, a goal of another category, a fixture it has
    not)."""
    orientation = click.orientation_index
    if click.family_action is not None:
        fixture_id = click.object_id or ""
        if not any(fixture.id == fixture_id for fixture in scene.fixtures):
            raise ClickRefused(
                f"this world has no fixture {fixture_id or '(none named)'}: "
                f"nothing to {click.family_action}"
            )
        object_id = goal_id = fixture_id
        orientation = None
    else:
        if click.goal_id is None:
            raise ClickRefused(f"{click.object_id} selected: now click a goal")
        object_id, goal_id = click.object_id or "", click.goal_id
        try:
            item, goal = scene.object(object_id), scene.goal(goal_id)
        except KeyError as missing:
            raise ClickRefused(f"the scene has no {missing.args[0]}") from None
        if not item.visible or not goal.visible:
            hidden = object_id if not item.visible else goal_id
            raise ClickRefused(f"{hidden} is hidden (inside a closed box)")
        if item.category.value != goal.category.value:
            raise ClickRefused(
                f"{object_id} is a {item.category.value}: it goes to a "
                f"{item.category.value} goal, not to {goal_id} ({goal.category.value})"
            )
        if orientation is not None and not 0 <= orientation < NUM_ORIENTATIONS:
            raise ClickRefused(f"orientation_index: must be in 0..{NUM_ORIENTATIONS - 1}")
        if orientation is None and goal.fixture is not None:
            orientation = nearest_orientation(goal.orientation)  # the fixture's slot's own
    return Action(
        decision_id=derived_id(episode_id, ":", str(step)),
        episode_id=episode_id,
        scene_sequence=scene.sequence,
        object_id=object_id,
        goal_id=goal_id,
        orientation_index=orientation,
        family_action=click.family_action,
        policy=policy,
        stamp=clock(),
    )


def same_decision(a: Action, b: Action) -> bool:
    """Whether ``a`` and ``b`` ask the robot for the same thing (ids, stamps and names apart)."""
    return (a.object_id, a.goal_id, a.orientation_index, a.family_action) == (
        b.object_id,
        b.goal_id,
        b.orientation_index,
        b.family_action,
    )


def describe(action: Action) -> str:
    """``action`` as the page's messages name it: ``object -> goal`` with the orientation's
    name, or ``<family action> <fixture>`` (``toggle rack_top``)."""
    if action.family_action is not None:
        return f"{action.family_action} {action.object_id}"
    turn = (
        f" ({ORIENTATION_NAMES[action.orientation_index]})"
        if action.orientation_index is not None
        else ""
    )
    return f"{action.object_id} -> {action.goal_id}{turn}"
