"""What a run needs from the machine, checked before anything starts, with the fix named.

Each check returns None when the need is met, else one sentence: what is missing and the
command that installs it. They are cheap (files and ``PATH``, no SAPIEN, no browser), so
``manigraph up`` and the services run them before starting or importing anything, and a
missing piece is one clear line instead of a traceback repeated by the supervisor. A service
refusing on one exits with :data:`~manigraph_shared.errors.CONFIG_EXIT_CODE`, which the
supervisor does not restart.
"""

from __future__ import annotations

import os
from pathlib import Path

#: Where the Vulkan loader looks for drivers (ICD manifests) when no variable overrides it.
VULKAN_ICD_DIRS = (
    Path("/etc/vulkan/icd.d"),
    Path("/usr/local/share/vulkan/icd.d"),
    Path("/usr/share/vulkan/icd.d"),
)
#: The Vulkan loader's own variables naming the driver manifests to use instead.
VULKAN_DRIVER_VARIABLES = ("VK_DRIVER_FILES", "VK_ICD_FILENAMES")

INSTALL_VULKAN = "sudo make vulkan (Debian 12: Mesa lavapipe, a Vulkan device on the CPU)"

Environ = os._Environ[str] | dict[str, str]


def vulkan_drivers(environ: Environ = os.environ) -> list[Path]:
    """The Vulkan driver manifests the loader would read here."""
    for variable in VULKAN_DRIVER_VARIABLES:
        if environ.get(variable):
            return [Path(p) for p in environ[variable].split(os.pathsep) if Path(p).is_file()]
    dirs = list(VULKAN_ICD_DIRS)
    for data in environ.get("XDG_DATA_DIRS", "").split(os.pathsep):
        if data:
            dirs.append(Path(data) / "vulkan" / "icd.d")
    return sorted(p for d in dirs if d.is_dir() for p in d.glob("*.json"))


def vulkan_problem(need: str, environ: Environ = os.environ) -> str | None:
    """Why ``need`` (e.g. "the rendered camera") cannot have a Vulkan device, or None."""
    if vulkan_drivers(environ):
        return None
    named = next((v for v in VULKAN_DRIVER_VARIABLES if environ.get(v)), None)
    where = f"{named}={environ[named]}" if named else ", ".join(map(str, VULKAN_ICD_DIRS))
    return (
        f"{need} needs a Vulkan device and no Vulkan driver is installed ({where}): "
        + INSTALL_VULKAN
    )
