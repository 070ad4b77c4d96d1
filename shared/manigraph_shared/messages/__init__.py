"""The message contract: every type on the bus, declared once beside its key expression."""

from manigraph_shared.messages.base import (
    CONTRACT_VERSION,
    MAX_PAYLOAD_BYTES,
    Delivery,
    Message,
    Quaternion,
    Vector3,
    key_matches,
    message_type_for_key,
)
from manigraph_shared.messages.decision import (
    REFUSAL_REASONS,
    Action,
    SkillState,
    SkillStatus,
)
from manigraph_shared.messages.episode import EpisodeEvent, EpisodePhase, EpisodeRequest
from manigraph_shared.messages.robot import GripperOp, RobotCommand, RobotFeedback
from manigraph_shared.messages.scene import (
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneFixture,
    SceneGoal,
    SceneObject,
)
from manigraph_shared.messages.status import Checkpoint, EstopState, ServiceState, ServiceStatus

__all__ = [
    "CONTRACT_VERSION",
    "MAX_PAYLOAD_BYTES",
    "REFUSAL_REASONS",
    "Action",
    "Checkpoint",
    "Delivery",
    "EpisodeEvent",
    "EpisodePhase",
    "EpisodeRequest",
    "EstopState",
    "GoalCategory",
    "GripperOp",
    "Message",
    "ObjectCategory",
    "Quaternion",
    "RobotCommand",
    "RobotFeedback",
    "Scene",
    "SceneFixture",
    "SceneGoal",
    "SceneObject",
    "ServiceState",
    "ServiceStatus",
    "SkillState",
    "SkillStatus",
    "Vector3",
    "key_matches",
    "message_type_for_key",
]

from manigraph_shared.messages.joints import (  # appended: the joint-level robot
    GripperTarget,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryPoint,
    JointTrajectoryResult,
)

__all__ += [
    "GripperTarget",
    "JointState",
    "JointTrajectoryCommand",
    "JointTrajectoryPoint",
    "JointTrajectoryResult",
]

from manigraph_shared.messages.explanation import (  # noqa: E402  (appended: the explainer)
    EXPLAINER_BUSY,
    EXPLAINER_WARMING_UP,
    ExplainedEdge,
    ExplainedNode,
    ExplainRequest,
    Explanation,
)

__all__ += [
    "EXPLAINER_BUSY",
    "EXPLAINER_WARMING_UP",
    "ExplainRequest",
    "ExplainedEdge",
    "ExplainedNode",
    "Explanation",
]

from manigraph_shared.messages.estop import EmergencyStop  # noqa: E402  (appended: the e-stop)

__all__ += ["EmergencyStop"]

from manigraph_shared.messages.camera import (  # noqa: E402  (appended: the camera)
    CameraInfo,
    CompressedImage,
    DepthEncoding,
    DepthImage,
    DetectedMarker,
    ImageFormat,
    MarkerDetections,
)
from manigraph_shared.messages.layout import (  # noqa: E402
    LayoutContainer,
    LayoutGoal,
    LayoutObject,
    TaskLayout,
)

__all__ += [
    "CameraInfo",
    "CompressedImage",
    "DepthEncoding",
    "DepthImage",
    "DetectedMarker",
    "ImageFormat",
    "LayoutContainer",
    "LayoutGoal",
    "LayoutObject",
    "MarkerDetections",
    "TaskLayout",
]

# Decoders built now, at import, before any thread decodes (msgspec builds its type
# information lazily and not thread-safely: Message.prepare).
for _type in Message.registry.values():
    _type.prepare()
del _type
