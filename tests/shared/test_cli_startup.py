"""Every ``manigraph`` process builds its parser from every installed subcommand, so a
subcommand module that imports a heavy library at module level slows down every process (the
router's too): torch alone took 10-90 s on a busy 2-core machine."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("torch", "torch_geometric", "sapien", "pinocchio", "mani_skill", "cv2")

LOAD_EVERY_COMMAND = f"""
import sys
from importlib.metadata import entry_points
for entry in entry_points(group="manigraph.commands"):
    entry.load()
print(",".join(name for name in {HEAVY!r} if name in sys.modules))
"""


def test_loading_every_subcommand_imports_no_heavy_library() -> None:
    done = subprocess.run(
        [sys.executable, "-c", LOAD_EVERY_COMMAND], capture_output=True, text=True, check=True
    )
    assert done.stdout.strip() == "", f"imported at start-up: {done.stdout.strip()}"
