"""A Foxglove layout for manigraph runs, built with foxglove-sdk's layout types.

The 3D panel needs no settings for ``/foxglove/scene`` and ``/foxglove/tf``; this layout adds
what is nice to have on top: the scene topic switched on, the camera on the table in the scene
frame, and beside it the planner's decision and its explanation in words. It is written to
``docs/foxglove-layout.json`` (checked for drift by a test) and printed by
``manigraph view --print-layout``; import it in Foxglove with Layouts → Import from file.
"""

from __future__ import annotations

import json

import foxglove.layouts as fl

from manigraph_shared.messages import Action, Explanation
from manigraph_tools.foxglove_bridge import SCENE_TOPIC


def layout(frame: str = "world") -> fl.Layout:
    three_d = fl.ThreeDeePanel(
        title="scene",
        config=fl.ThreeDeeConfig(
            follow_tf=frame,
            follow_mode="follow-none",
            camera_state=fl.ThreeDeeCameraState(
                distance=1.6, phi=55.0, theta_offset=30.0, target_offset=(0.4, 0.0, 0.0)
            ),
            # Transform topics need no switch: the panel always reads them.
            topics={SCENE_TOPIC: fl.BaseRendererSceneUpdateTopicSettings(visible=True)},
        ),
    )
    words = fl.RawMessagesPanel(
        title="why",
        config=fl.RawMessagesConfig(topic_path=f"{Explanation.key}.sentence"),
    )
    decision = fl.RawMessagesPanel(
        title="decision",
        config=fl.RawMessagesConfig(topic_path=Action.key, expansion="all"),
    )
    side = fl.SplitContainer(
        direction="column", items=[fl.SplitItem(content=decision), fl.SplitItem(content=words)]
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[fl.SplitItem(proportion=3, content=three_d), fl.SplitItem(content=side)],
        )
    )


def layout_json() -> str:
    """The layout as a file: indented, keys in a stable order, newline at the end."""
    return json.dumps(json.loads(layout().to_json()), indent=2) + "\n"
