"""A Foxglove layout for manigraph runs, built with foxglove-sdk's layout types.

The 3D panel needs no settings for ``/foxglove/scene`` and ``/foxglove/tf``; this layout adds
what is nice to have on top: the scene topic switched on and the 3D camera on the table in the
scene frame; beside it the camera's image with the markers perception found in it
(``/camera/<name>/...``, :mod:`manigraph_tools.foxglove_camera`) above a plot of the arm's
joint angles; and on the right the planner's decision and its explanation as tables, and the
explanation in words. It is written to
``docs/foxglove-layout.json`` (checked for drift by a test) and printed by
``manigraph view --print-layout``; import it in Foxglove with Layouts → Import from file.
"""

from __future__ import annotations

import json

import foxglove.layouts as fl

from manigraph_shared.messages import Action, Explanation, JointState
from manigraph_shared.panda import ARM_JOINTS
from manigraph_tools.foxglove_bridge import SCENE_TOPIC

#: The physics sim's camera (``manigraph sim --camera``), the one the layout's Image panel shows.
CAMERA = "front"


def layout(frame: str = "world", camera: str = CAMERA) -> fl.Layout:
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
    image = fl.ImagePanel(
        title="camera",
        config=fl.ImageConfig(
            image_mode=fl.ImageModeConfig(
                image_topic=f"/camera/{camera}/image",
                calibration_topic=f"/camera/{camera}/calibration",
                annotations={f"/camera/{camera}/markers": fl.ImageAnnotationSettings(visible=True)},
            )
        ),
    )
    joints = fl.PlotPanel(
        title="joint angles",
        config=fl.PlotConfig(
            paths=[
                fl.PlotSeries(
                    value=f"{JointState.key}.positions[{index}]",
                    label=name,
                    timestamp_method="receiveTime",
                    enabled=True,
                )
                for index, name in enumerate(ARM_JOINTS)
            ],
            show_legend=True,
            y_axis_label="rad",
        ),
    )
    decision = fl.TablePanel(title="decision", config=fl.TableConfig(topic_path=Action.key))
    explanation = fl.TablePanel(
        title="explanation", config=fl.TableConfig(topic_path=Explanation.key)
    )
    words = fl.RawMessagesPanel(
        title="why",
        config=fl.RawMessagesConfig(topic_path=f"{Explanation.key}.sentence"),
    )
    middle = fl.SplitContainer(
        direction="column", items=[fl.SplitItem(content=image), fl.SplitItem(content=joints)]
    )
    side = fl.SplitContainer(
        direction="column",
        items=[
            fl.SplitItem(content=decision),
            fl.SplitItem(proportion=2, content=explanation),
            fl.SplitItem(content=words),
        ],
    )
    return fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[
                fl.SplitItem(proportion=3, content=three_d),
                fl.SplitItem(proportion=2, content=middle),
                fl.SplitItem(proportion=2, content=side),
            ],
        )
    )


def layout_json() -> str:
    """The layout as a file: indented, keys in a stable order, newline at the end."""
    return json.dumps(json.loads(layout().to_json()), indent=2) + "\n"
