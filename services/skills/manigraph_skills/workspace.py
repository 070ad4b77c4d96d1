"""The box a skill may reach into (shared with the sim, which refuses commands outside it)."""

from manigraph_shared.workspace import Workspace

__all__ = ["Workspace"]
