"""Imitation learning of GNN policies from recorded demonstrations (paper, eq. (ce))."""
