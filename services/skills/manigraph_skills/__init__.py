"""manigraph."""
