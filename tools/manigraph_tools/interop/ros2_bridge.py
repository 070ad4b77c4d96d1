"""``manigraph ros2``: the live bus republished as ROS 2 messages in rmw_zenoh's wire format.

A ROS 2 system running ``rmw_zenoh_cpp`` (Jazzy message definitions) and connected to the same
Zenoh router sees ``/manigraph/joint_states`` (``sensor_msgs/msg/JointState``), ``/tf``
(``tf2_msgs/msg/TFMessage``: the Panda's links from each joint state, the robot base on the
first scene) and ``/manigraph/scene_markers`` (``visualization_msgs/msg/MarkerArray``). The
conversion is :mod:`.ros2_messages` (the same as the bag export), the keys, attachments and
liveliness tokens :mod:`.rmw_zenoh`.

The bridge is a service like the others: state streams are coalesced to the newest sample
waiting (``Service.on``), so a slow ROS side never queues the bus; every rmw_zenoh publisher is
declared with congestion control DROP, like the contract's state streams.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass

import zenoh

from manigraph_shared.bus import Bus
from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import JointState, Scene
from manigraph_shared.options import (
    Interval,
    Options,
    option,
)
from manigraph_shared.service import Service
from manigraph_tools.interop import rmw_zenoh
from manigraph_tools.interop.ros2_messages import (
    JOINT_STATE,
    JOINT_STATES_TOPIC,
    MARKER_ARRAY,
    SCENE_MARKERS_TOPIC,
    TF_MESSAGE,
    TF_TOPIC,
    Converter,
    RosMessage,
    typestore,
)

#: What the bridge publishes: topic and type, in entity-id order.
PUBLISHED = (
    (JOINT_STATES_TOPIC, JOINT_STATE),
    (TF_TOPIC, TF_MESSAGE),
    (SCENE_MARKERS_TOPIC, MARKER_ARRAY),
)


@dataclass(frozen=True)
class Ros2BridgeOptions(Options):
    domain_id: int = option(0, help="ROS_DOMAIN_ID of the ROS 2 system", within=Interval(0, 232))
    node_name: str = option("manigraph_bridge", help="ROS 2 node name in liveliness tokens")

    def __post_init__(self) -> None:
        super().__post_init__()
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]{0,254}", self.node_name):
            raise ConfigError("node_name", f"'{self.node_name}' is not a ROS 2 node name")


class RmwZenohPublisher:
    """One ROS 2 publisher in rmw_zenoh's layout: key, attachment with a growing sequence
    number, and its liveliness token."""

    def __init__(
        self,
        session: zenoh.Session,
        options: Ros2BridgeOptions,
        entity_id: int,
        topic: str,
        msgtype: str,
    ) -> None:
        type_hash = typestore().hash_rihs01(msgtype)
        session_id = str(session.info.zid())
        self.key = rmw_zenoh.topic_key(options.domain_id, topic, msgtype, type_hash)
        self.gid = rmw_zenoh.publisher_gid(session_id, entity_id)
        self.sequence_number = 0
        self._publisher = session.declare_publisher(
            self.key, congestion_control=zenoh.CongestionControl.DROP
        )
        self._token = session.liveliness().declare_token(
            rmw_zenoh.publisher_token(
                options.domain_id,
                session_id,
                0,
                entity_id,
                "",
                options.node_name,
                topic,
                msgtype,
                type_hash,
            )
        )

    def put(self, payload: bytes) -> None:
        self.sequence_number += 1
        attachment = rmw_zenoh.Attachment(self.sequence_number, time.time_ns(), self.gid)
        self._publisher.put(payload, attachment=attachment.encode())

    def undeclare(self) -> None:
        self._publisher.undeclare()
        self._token.undeclare()


class Ros2Bridge(Service):
    name = "ros2"

    def __init__(self, bus: Bus, options: Ros2BridgeOptions) -> None:
        super().__init__(bus)
        self.options = options
        self.converter = Converter()
        self.publishers: dict[str, RmwZenohPublisher] = {}
        self.published = 0

    def setup(self) -> None:
        # rmw_zenoh's keys live outside manigraph/**, so they are declared on the session
        # itself, not through the bus's contract-typed (and cell-scoped) publishers.
        session = self.bus.session
        session_id = str(session.info.zid())
        self._node_token = session.liveliness().declare_token(
            rmw_zenoh.node_token(self.options.domain_id, session_id, 0, "", self.options.node_name)
        )
        for entity_id, (topic, msgtype) in enumerate(PUBLISHED, start=1):
            self.publishers[topic] = RmwZenohPublisher(
                session, self.options, entity_id, topic, msgtype
            )
        self.on(JointState, self._forward)
        self.on(Scene, self._forward)
        self.log.info(
            "republishing on ROS_DOMAIN_ID %d: %s",
            self.options.domain_id,
            ", ".join(p.key for p in self.publishers.values()),
        )

    def _forward(self, message: JointState | Scene) -> None:
        for ros in self.converter.convert(message):
            self._put(ros)

    def _put(self, ros: RosMessage) -> None:
        publisher = self.publishers.get(ros.topic)
        if publisher is not None:
            publisher.put(ros.cdr())
            self.published += 1

    def teardown(self) -> None:
        for publisher in self.publishers.values():
            publisher.undeclare()
        self._node_token.undeclare()
