"""`manigraph ros2` over a real router on loopback: a JointState published on the manigraph bus
arrives on rmw_zenoh's key for `/manigraph/joint_states`, as CDR that rosbags' deserializer
reads, with rmw_zenoh's attachment; /tf and the scene markers arrive too, and the bridge's
liveliness tokens announce its node and publishers. No ROS 2 node runs here: the subscriber
is a bare Zenoh session, the decoder rosbags."""

from __future__ import annotations

import queue
import time

import pytest
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_typestore

from manigraph_shared.messages import (
    GoalCategory,
    JointState,
    ObjectCategory,
    Scene,
    SceneGoal,
    SceneObject,
    Vector3,
)
from manigraph_shared.panda import ARM_JOINTS
from manigraph_testkit.testing import Stack, open_raw_session

pytestmark = pytest.mark.integration

STORE = get_typestore(Stores.ROS2_JAZZY)
DOMAIN = 7


def documented_key(topic: str, msgtype: str) -> str:
    """rmw_zenoh's docs/design.md: <domain_id>/<fully_qualified_name>/<type_name>/<type_hash>."""
    package, kind, name = msgtype.split("/")
    type_hash = STORE.hash_rihs01(msgtype)
    return f"{DOMAIN}/{topic.lstrip('/')}/{package}::{kind}::dds_::{name}_/{type_hash}"


def test_joint_states_tf_and_markers_arrive_in_rmw_zenohs_format(running_stack: Stack) -> None:
    running_stack.start("router")
    running_stack.start("ros2", "ros2", "--domain-id", str(DOMAIN))
    samples: queue.Queue[zenoh.Sample] = queue.Queue()
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "ros2")
        # Opened once the router answers: a bare session tries to connect only once.
        session = open_raw_session(running_stack.endpoint)
        try:
            subscriber = session.declare_subscriber(f"{DOMAIN}/**", samples.put)
            state = JointState(
                joint_names=list(ARM_JOINTS),
                positions=[0.1, -0.785398163397, 0.2, -2.35619449, 0.3, 1.57079632679, 0.785],
                gripper_width=0.06,
                stamp=1_767_000_000.25,
            )
            scene = Scene(
                episode_id="ep",
                stamp=1_767_000_000.5,
                sequence=0,
                objects=[
                    SceneObject(
                        id="block_0",
                        category=ObjectCategory.BLOCK,
                        position=Vector3(x=0.45, y=-0.1, z=0.02),
                        size=Vector3(x=0.04, y=0.04, z=0.04),
                    )
                ],
                goals=[
                    SceneGoal(
                        id="goal_0",
                        category=GoalCategory.BLOCK,
                        position=Vector3(x=0.5, y=0.1, z=0.02),
                    )
                ],
            )
            received: dict[str, list[zenoh.Sample]] = {}
            wanted = {
                documented_key("/manigraph/joint_states", "sensor_msgs/msg/JointState"),
                documented_key("/tf", "tf2_msgs/msg/TFMessage"),
                documented_key("/manigraph/scene_markers", "visualization_msgs/msg/MarkerArray"),
            }
            deadline = time.monotonic() + 30
            # Publish until every topic has arrived twice (the first samples may go out before
            # the bridge's subscriptions have reached the router).
            while time.monotonic() < deadline and not all(
                len(received.get(key, [])) >= 2 for key in wanted
            ):
                bus.publish(scene)
                bus.publish(state)
                try:
                    while True:
                        sample = samples.get(timeout=0.2)
                        received.setdefault(str(sample.key_expr), []).append(sample)
                except queue.Empty:
                    pass
            tokens = [
                str(reply.ok.key_expr)
                for reply in session.liveliness().get(f"@ros2_lv/{DOMAIN}/**", timeout=2.0)
                if reply.ok is not None
            ]
            subscriber.undeclare()
        finally:
            session.close()

    assert set(received) == wanted, f"got {sorted(received)}"

    joint_key = documented_key("/manigraph/joint_states", "sensor_msgs/msg/JointState")
    first, second = received[joint_key][:2]
    message = STORE.deserialize_cdr(first.payload.to_bytes(), "sensor_msgs/msg/JointState")
    assert list(message.name) == [*ARM_JOINTS, "panda_finger_joint1", "panda_finger_joint2"]
    assert (
        max(abs(a - b) for a, b in zip(message.position[:7], state.positions, strict=True)) < 1e-9
    )
    assert list(message.position[7:]) == [0.03, 0.03]
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (1_767_000_000, 250_000_000)

    attachments = []
    for sample in (first, second):
        assert sample.attachment is not None
        sequence, stamp, gid = zenoh.ext.z_deserialize(
            tuple[zenoh.ext.Int64, zenoh.ext.Int64, bytes], sample.attachment
        )
        attachments.append((int(sequence), int(stamp), gid))
    assert attachments[1][0] == attachments[0][0] + 1  # one sequence per publisher
    assert abs(attachments[0][1] / 1e9 - time.time()) < 60  # the source timestamp: now, in ns
    assert len(attachments[0][2]) == 16 and attachments[0][2] == attachments[1][2]

    tf = STORE.deserialize_cdr(
        received[documented_key("/tf", "tf2_msgs/msg/TFMessage")][-1].payload.to_bytes(),
        "tf2_msgs/msg/TFMessage",
    )
    assert {t.child_frame_id for t in tf.transforms} >= {"panda_link0", "panda_link7", "panda_hand"}
    markers = STORE.deserialize_cdr(
        received[documented_key("/manigraph/scene_markers", "visualization_msgs/msg/MarkerArray")][
            -1
        ].payload.to_bytes(),
        "visualization_msgs/msg/MarkerArray",
    )
    placed = {(m.ns, m.text): m.pose.position.x for m in markers.markers[1:]}
    assert placed == {("objects", "block_0"): 0.45, ("goals", "goal_0"): 0.5}

    assert any(token.endswith("/NN/%/%/manigraph_bridge") for token in tokens), tokens
    joint_token = [t for t in tokens if "/MP/" in t and "%manigraph%joint_states" in t]
    assert joint_token and joint_token[0].split("/")[-3:-1] == joint_key.split("/")[-2:]
