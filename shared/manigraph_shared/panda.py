"""The Franka Panda as both the physics sim and the skills service see it.

Joint names and frames are those of the Panda URDF shipped with this package
(``manigraph_shared/robots/panda/``: ManiSkill's ``panda_v2.urdf`` and the meshes it
references, with their Apache 2.0 licence), so the skills image has the robot without
mani-skill. Other variants of ManiSkill's Panda are located in the mani-skill package when it
is installed (``importlib.util.find_spec``), never imported or downloaded.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from manigraph_shared.errors import ConfigError

ARM_JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGER_JOINTS = ("panda_finger_joint1", "panda_finger_joint2")
#: The tool centre point between the fingertips; grasp poses are poses of this frame.
TCP_FRAME = "panda_hand_tcp"
#: Franka's "ready" pose, hand turned a quarter: TCP at (0.31, 0, 0.49) m, fingers pointing
#: down and closing along x. High and close to the base, clear of any stack on the table.
HOME_Q = np.array([0.0, -np.pi / 4, 0.0, -3 * np.pi / 4, 0.0, np.pi / 2, -np.pi / 4])
#: Finger opening (each finger, metres) when open; closed is 0.
FINGER_OPEN = 0.04
#: The open fingers' collision shapes, measured in the TCP frame of the URDF: they reach
#: this far out from the TCP along the closing axis (the pads' outer faces), ...
FINGER_REACH = 0.066
#: ... are this wide across it (half width) ...
FINGER_HALF_WIDTH = 0.011
#: ... and span from this far below the TCP to this far above it.
FINGER_BELOW_TCP = 0.0095
FINGER_ABOVE_TCP = 0.045


#: The Panda description shipped as package data.
SHIPPED_PANDA = Path(__file__).parent / "robots" / "panda"


def panda_urdf_path(name: str = "panda_v2.urdf") -> Path:
    """The Panda URDF: the shipped copy, else the one inside the mani-skill package.

    Raises:
        ConfigError: not shipped, and mani-skill is not installed or lacks the file.
    """
    if (SHIPPED_PANDA / name).is_file():
        return SHIPPED_PANDA / name
    spec = importlib.util.find_spec("mani_skill")
    if spec is None or not spec.submodule_search_locations:
        raise ConfigError("panda_urdf", "mani-skill is not installed; it ships the Panda URDF")
    path = Path(next(iter(spec.submodule_search_locations))) / "assets/robots/panda" / name
    if not path.is_file():
        raise ConfigError("panda_urdf", f"{path} does not exist in the mani-skill package")
    return path
