"""Motion for a Franka Panda: Pinocchio kinematics, damped-least-squares IK, a top-down
PickAndPlace waypoint plan and time-parameterised joint trajectories.

Pure computation: nothing here talks to a robot or the bus, so a hardware driver and the
simulated Panda plan with exactly the same code.
"""

from manigraph_skills.motion.ik import IKResult, IKSolver
from manigraph_skills.motion.model import HOME_Q, PandaModel, panda_urdf_path
from manigraph_skills.motion.plan import GraspPlanner, PlanConfig
from manigraph_skills.motion.trajectory import JointTrajectory

__all__ = [
    "HOME_Q",
    "GraspPlanner",
    "IKResult",
    "IKSolver",
    "JointTrajectory",
    "PandaModel",
    "PlanConfig",
    "panda_urdf_path",
]
