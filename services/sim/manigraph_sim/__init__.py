"""manigraph's sim service: the world the robot acts in (geometric or SAPIEN physics).

Importing SAPIEN on a machine without a system ``libvulkan`` warns ``Failed to find system
libvulkan`` and falls back to SAPIEN's own copy. Physics needs no Vulkan at all, and where the
camera or a video is asked for, the sim checks for a Vulkan device itself and says what to
install (``manigraph_shared.preflight``), so SAPIEN's warning is silenced here, before any
module of the sim imports SAPIEN.
"""

import warnings

warnings.filterwarnings("ignore", message=r"Failed to find system libvulkan", category=UserWarning)
