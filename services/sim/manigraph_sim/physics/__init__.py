"""The physics backend: a SAPIEN 3 world with the Franka Panda from the mani-skill package.

Registered in ``manigraph_sim.backends`` without importing SAPIEN, so ``manigraph sim
--backend geometric`` stays fast; SAPIEN is imported when a physics backend is created.
"""
