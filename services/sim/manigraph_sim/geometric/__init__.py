"""The fast geometric world: boxes that rest on what is below them, no dynamics."""

from manigraph_sim.geometric import backend  # noqa: F401  (registers "geometric")
