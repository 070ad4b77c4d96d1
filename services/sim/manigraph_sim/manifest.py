"""What the sim service consumes and produces (see ``manigraph_shared.manifest``)."""

from manigraph_shared.manifest import WORLD_ABILITIES, Manifest, port
from manigraph_shared.messages import (
    CameraInfo,
    CompressedImage,
    DepthImage,
    EmergencyStop,
    EpisodeEvent,
    EpisodeRequest,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    RobotCommand,
    RobotFeedback,
    Scene,
    ServiceStatus,
    SkillStatus,
    TaskLayout,
)

#: The geometric world takes Cartesian gripper commands; the physics world moves a jointed arm.
GRIPPER = "gripper_commands"
JOINTS = "joint_trajectories"
#: The physics world can render a tripod camera (``--camera``) for perception.
CAMERA = "camera"

MANIFEST = Manifest(
    service="sim",
    summary="geometric or physics world",
    consumes=(
        port(EmergencyStop),
        port(RobotCommand, GRIPPER),
        port(JointTrajectoryCommand, JOINTS),
        port(SkillStatus),
    ),
    produces=(
        port(Scene),
        port(EpisodeEvent),
        port(RobotFeedback, GRIPPER),
        port(JointTrajectoryResult, JOINTS),
        port(JointState, JOINTS),
        port(CompressedImage, CAMERA),
        port(DepthImage, CAMERA),
        port(CameraInfo, CAMERA),
        port(TaskLayout, CAMERA),
        port(ServiceStatus),
    ),
    serves=(port(EpisodeRequest),),
    variant_option="backend",
    variants=dict(WORLD_ABILITIES),  # geometric: GRIPPER; physics: JOINTS, CAMERA
)
