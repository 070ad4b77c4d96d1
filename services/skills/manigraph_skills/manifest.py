"""What the skills service consumes and produces (see ``manigraph_shared.manifest``).

Each robot driver needs one ability from the world it drives: ``sim-gripper`` the geometric
world's gripper commands, ``panda-sim`` a simulated jointed arm; ``franka`` needs the real
robot, which no sim offers, so ``manigraph up`` never picks it.
"""

from manigraph_shared.manifest import Manifest, port
from manigraph_shared.messages import (
    Action,
    EmergencyStop,
    JointState,
    JointTrajectoryCommand,
    JointTrajectoryResult,
    RobotCommand,
    RobotFeedback,
    Scene,
    ServiceStatus,
    SkillStatus,
)

GRIPPER = "gripper_commands"
JOINTS = "joint_trajectories"
HARDWARE = "franka_hardware"

MANIFEST = Manifest(
    service="skills",
    summary="PickAndPlace + robot driver",
    consumes=(
        port(EmergencyStop),
        port(Action),
        port(Scene),
        port(RobotFeedback, GRIPPER),
        port(JointTrajectoryResult, JOINTS),
        port(JointState, JOINTS),
    ),
    produces=(
        port(SkillStatus),
        port(RobotCommand, GRIPPER),
        port(JointTrajectoryCommand, JOINTS),
        port(ServiceStatus),
    ),
    variant_option="driver",
    variants={
        "sim-gripper": frozenset({GRIPPER}),
        "panda-sim": frozenset({JOINTS}),
        "franka": frozenset({HARDWARE}),
    },
)
