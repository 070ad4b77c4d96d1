"""Contract messages as ROS 2 standard messages (rosbags' typestore classes, ROS 2 Jazzy).

One mapping, used by the bag exporter (:mod:`.ros2_bag`) and the live bridge
(:mod:`.ros2_bridge`):

* ``Scene`` → ``/manigraph/scene_markers``, ``visualization_msgs/msg/MarkerArray``;
* ``JointState`` → ``/manigraph/joint_states``, ``sensor_msgs/msg/JointState``;
* a Panda's ``JointState`` (and the first ``Scene``, for the robot base) → ``/tf``,
  ``tf2_msgs/msg/TFMessage``;
* ``CompressedImage`` → ``/manigraph/camera/<camera>/image/compressed``,
  ``sensor_msgs/msg/CompressedImage``;
* ``CameraInfo`` → ``/manigraph/camera/<camera>/camera_info``, ``sensor_msgs/msg/CameraInfo``;
* ``Action``, ``Explanation``, ``EpisodeEvent`` → ``/`` + the contract key
  (``/manigraph/planner/action``), ``std_msgs/msg/String`` holding the message's own JSON.

Every header stamp is the contract message's own ``stamp`` (seconds since the Unix epoch).
The ``JointState``'s gripper opening becomes the two finger joints (half the width each, as
the Panda URDF's prismatic fingers are), so ``robot_state_publisher`` can use it as it is.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from manigraph_shared.colours import colour_of, describe
from manigraph_shared.messages import (
    Action,
    CameraInfo,
    CompressedImage,
    EpisodeEvent,
    Explanation,
    JointState,
    Message,
    ObjectCategory,
    Scene,
)
from manigraph_shared.panda import FINGER_JOINTS
from manigraph_tools.panda_frames import BASE_FRAME, CHAIN, is_panda, link_poses

#: The ROS 2 distribution whose message definitions (and so type hashes) are written.
ROS_DISTRO = Stores.ROS2_JAZZY

SCENE_MARKERS_TOPIC = "/manigraph/scene_markers"
JOINT_STATES_TOPIC = "/manigraph/joint_states"
TF_TOPIC = "/tf"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
JOINT_STATE = "sensor_msgs/msg/JointState"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
STRING = "std_msgs/msg/String"
#: Contract types written as ``std_msgs/msg/String`` holding their JSON.
AS_JSON: tuple[type[Message], ...] = (Action, Explanation, EpisodeEvent)

# visualization_msgs/msg/Marker constants
CUBE, ADD, DELETEALL = 1, 0, 3
GOAL_ALPHA = 0.35
DEFAULT_SIZE = (0.04, 0.04, 0.04)
#: A fixture of any kind: translucent grey; one without a size is a marker of this edge.
FIXTURE_RGBA = (0.6, 0.62, 0.66, 0.35)
FIXTURE_MARKER = 0.03


@cache
def typestore() -> Typestore:
    return get_typestore(ROS_DISTRO)


@dataclass(frozen=True)
class RosMessage:
    """One ROS 2 message to write: topic, type name and the typestore instance."""

    topic: str
    msgtype: str
    message: Any

    def cdr(self) -> bytes:
        return bytes(typestore().serialize_cdr(self.message, self.msgtype))


def _new(msgtype: str, **fields: Any) -> Any:
    return typestore().types[msgtype](**fields)


def ros_time(stamp: float) -> Any:
    """Seconds since the epoch as ``builtin_interfaces/msg/Time``: whole seconds, then the
    fraction rounded to a nanosecond (``stamp * 1e9`` would lose ~100 ns to float64)."""
    sec = math.floor(stamp)
    nanosec = round((stamp - sec) * 1e9)
    if nanosec >= 1_000_000_000:
        sec, nanosec = sec + 1, nanosec - 1_000_000_000
    return _new("builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)


def header(stamp: float, frame_id: str) -> Any:
    return _new("std_msgs/msg/Header", stamp=ros_time(stamp), frame_id=frame_id)


# --- joints and transforms -------------------------------------------------------------------
def joint_state(state: JointState) -> Any:
    names = list(state.joint_names)
    positions = list(state.positions)
    if is_panda(state):
        names += FINGER_JOINTS
        positions += [state.gripper_width / 2] * 2
    return _new(
        JOINT_STATE,
        header=header(state.stamp, ""),
        name=names,
        position=np.asarray(positions, dtype=np.float64),
        velocity=np.zeros(0, dtype=np.float64),
        effort=np.zeros(0, dtype=np.float64),
    )


def _transform(stamp: float, parent: str, child: str, xyz: Any, quat: Any) -> Any:
    return _new(
        "geometry_msgs/msg/TransformStamped",
        header=header(stamp, parent),
        child_frame_id=child,
        transform=_new(
            "geometry_msgs/msg/Transform",
            translation=_new("geometry_msgs/msg/Vector3", x=xyz[0], y=xyz[1], z=xyz[2]),
            rotation=_new(
                "geometry_msgs/msg/Quaternion", x=quat[0], y=quat[1], z=quat[2], w=quat[3]
            ),
        ),
    )


def base_tf(scene_frame: str, stamp: float) -> Any:
    """The robot base at the origin of the scene frame (as the physics world loads it)."""
    return _new(
        TF_MESSAGE,
        transforms=[_transform(stamp, scene_frame, BASE_FRAME, (0, 0, 0), (0, 0, 0, 1))],
    )


def robot_tf(state: JointState, scene_frame: str) -> Any:
    """The base in the scene frame and every link of the Panda's chain, parent to child."""
    parents = {link.child: link.parent for link in CHAIN}
    transforms = [_transform(state.stamp, scene_frame, BASE_FRAME, (0, 0, 0), (0, 0, 0, 1))]
    transforms += [
        _transform(state.stamp, parents[child], child, xyz, quat)
        for child, (xyz, quat) in link_poses(state).items()
    ]
    return _new(TF_MESSAGE, transforms=transforms)


# --- the scene ---------------------------------------------------------------------------------
def marker_id(entity_id: str) -> int:
    """A stable int32 marker id per entity id, the same in every scene of a run."""
    return zlib.crc32(entity_id.encode()) & 0x7FFFFFFF


def _colour(r: float, g: float, b: float, a: float = 1.0) -> Any:
    return _new("std_msgs/msg/ColorRGBA", r=r, g=g, b=b, a=a)


def _object_colour(
    entity_id: str, category: ObjectCategory, visible: bool, attributes: Mapping[str, object]
) -> Any:
    alpha = 1.0 if visible else 0.3
    named = colour_of(attributes)
    if named is not None:  # the task's own colour (a colour-sort block is drawn red)
        r, g, b = named
        return _colour(r, g, b, alpha)
    if category is ObjectCategory.COVER:
        return _colour(0.72, 0.53, 0.32, alpha)
    hue = marker_id(entity_id) % 360 / 360
    return _colour(
        0.5 + 0.4 * math.cos(2 * math.pi * hue),
        0.5 + 0.4 * math.cos(2 * math.pi * (hue - 1 / 3)),
        0.5 + 0.4 * math.cos(2 * math.pi * (hue - 2 / 3)),
        alpha,
    )


def _cube(
    ns: str, entity_id: str, stamp: float, frame: str, pose: Any, size: Any, colour: Any
) -> Any:
    return _new(
        "visualization_msgs/msg/Marker",
        header=header(stamp, frame),
        ns=ns,
        id=marker_id(entity_id),
        type=CUBE,
        action=ADD,
        pose=pose,
        scale=_new("geometry_msgs/msg/Vector3", x=size[0], y=size[1], z=size[2]),
        color=colour,
        lifetime=_new("builtin_interfaces/msg/Duration", sec=0, nanosec=0),
        frame_locked=False,
        points=[],
        colors=[],
        texture_resource="",
        texture=_new(
            COMPRESSED_IMAGE, header=header(0.0, ""), format="", data=np.zeros(0, np.uint8)
        ),
        uv_coordinates=[],
        text=entity_id,
        mesh_resource="",
        mesh_file=_new("visualization_msgs/msg/MeshFile", filename="", data=np.zeros(0, np.uint8)),
        mesh_use_embedded_materials=False,
    )


def _pose(position: Any, orientation: Any) -> Any:
    return _new(
        "geometry_msgs/msg/Pose",
        position=_new("geometry_msgs/msg/Point", x=position.x, y=position.y, z=position.z),
        orientation=_new(
            "geometry_msgs/msg/Quaternion",
            x=orientation.x,
            y=orientation.y,
            z=orientation.z,
            w=orientation.w,
        ),
    )


def scene_markers(scene: Scene) -> Any:
    """A ``DELETEALL`` marker, then one cube per object (``ns`` objects), per goal (``ns``
    goals, translucent; green when filled, orange when free) and per fixture of any kind
    (``ns`` fixtures, translucent grey, its size or a small marker at its handle, its text
    ``id (kind ..., state)``), ids stable per entity id.

    A goal is drawn the size of the scene's first object of its category (the contract gives
    goals no size)."""
    frame, stamp = scene.frame_id, scene.stamp
    clear = _cube("", "", stamp, frame, _pose_identity(), DEFAULT_SIZE, _colour(0, 0, 0, 0))
    clear.action, clear.id, clear.text = DELETEALL, 0, ""
    markers = [clear]
    sizes: dict[str, tuple[float, float, float]] = {}
    for item in scene.objects:
        sizes.setdefault(item.category.value, item.size.as_tuple())
        colour = _object_colour(item.id, item.category, item.visible, item.attributes)
        pose = _pose(item.position, item.orientation)
        cube = _cube("objects", item.id, stamp, frame, pose, item.size.as_tuple(), colour)
        if item.attributes:
            cube.text = f"{item.id} ({describe(item.attributes)})"
        markers.append(cube)
    for goal in scene.goals:
        alpha = GOAL_ALPHA if goal.visible else GOAL_ALPHA / 3
        colour = _colour(0.18, 0.8, 0.25, alpha) if goal.filled else _colour(1.0, 0.6, 0.1, alpha)
        size = sizes.get(goal.category.value, DEFAULT_SIZE)
        cube = _cube(
            "goals", goal.id, stamp, frame, _pose(goal.position, goal.orientation), size, colour
        )
        if goal.accepts:
            cube.text = f"{goal.id} (accepts {describe(goal.accepts)})"
        markers.append(cube)
    for fixture in scene.fixtures:
        size = fixture.size.as_tuple() if fixture.size else (FIXTURE_MARKER,) * 3
        pose = _pose(fixture.position, fixture.orientation)
        cube = _cube("fixtures", fixture.id, stamp, frame, pose, size, _colour(*FIXTURE_RGBA))
        cube.text = f"{fixture.id} ({describe({'kind': fixture.kind, **fixture.state})})"
        markers.append(cube)
    return _new(MARKER_ARRAY, markers=markers)


def _pose_identity() -> Any:
    return _new(
        "geometry_msgs/msg/Pose",
        position=_new("geometry_msgs/msg/Point", x=0.0, y=0.0, z=0.0),
        orientation=_new("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0),
    )


# --- the camera ---------------------------------------------------------------------------------
def camera_topics(camera: str) -> tuple[str, str]:
    """The image and camera-info topics of ``camera`` (image_transport's names)."""
    return (
        f"/manigraph/camera/{camera}/image/compressed",
        f"/manigraph/camera/{camera}/camera_info",
    )


def compressed_image(image: CompressedImage) -> Any:
    return _new(
        COMPRESSED_IMAGE,
        header=header(image.stamp, image.camera),
        format=image.format.value,
        data=np.frombuffer(image.data, dtype=np.uint8),
    )


def camera_info(info: CameraInfo) -> Any:
    """OpenCV's pinhole model: ``plumb_bob`` for 5 coefficients, else ``rational_polynomial``."""
    k = info.camera_matrix
    projection = [k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, k[6], k[7], k[8], 0.0]
    return _new(
        CAMERA_INFO,
        header=header(info.stamp, info.camera),
        height=info.height,
        width=info.width,
        distortion_model="plumb_bob" if len(info.distortion) <= 5 else "rational_polynomial",
        d=np.asarray(info.distortion, dtype=np.float64),
        k=np.asarray(k, dtype=np.float64),
        r=np.eye(3, dtype=np.float64).reshape(9),
        p=np.asarray(projection, dtype=np.float64),
        binning_x=0,
        binning_y=0,
        roi=_new(
            "sensor_msgs/msg/RegionOfInterest",
            x_offset=0,
            y_offset=0,
            height=0,
            width=0,
            do_rectify=False,
        ),
    )


def json_string(message: Message) -> Any:
    return _new(STRING, data=message.to_json())


class Converter:
    """Contract messages in, ROS 2 messages out; keeps the scene frame and whether the robot
    base has been sent (once, on the first scene, when no joint state names the links)."""

    def __init__(self) -> None:
        self.scene_frame = "world"
        self._base_sent = False

    def convert(self, message: Message) -> list[RosMessage]:
        if isinstance(message, JointState):
            out = [RosMessage(JOINT_STATES_TOPIC, JOINT_STATE, joint_state(message))]
            if is_panda(message):
                self._base_sent = True
                out.append(RosMessage(TF_TOPIC, TF_MESSAGE, robot_tf(message, self.scene_frame)))
            return out
        if isinstance(message, Scene):
            self.scene_frame = message.frame_id
            out = [RosMessage(SCENE_MARKERS_TOPIC, MARKER_ARRAY, scene_markers(message))]
            if not self._base_sent:
                self._base_sent = True
                out.append(
                    RosMessage(TF_TOPIC, TF_MESSAGE, base_tf(message.frame_id, message.stamp))
                )
            return out
        if isinstance(message, CompressedImage):
            topic = camera_topics(message.camera)[0]
            return [RosMessage(topic, COMPRESSED_IMAGE, compressed_image(message))]
        if isinstance(message, CameraInfo):
            topic = camera_topics(message.camera)[1]
            return [RosMessage(topic, CAMERA_INFO, camera_info(message))]
        if isinstance(message, AS_JSON):
            return [RosMessage("/" + message.key_for(), STRING, json_string(message))]
        return []
