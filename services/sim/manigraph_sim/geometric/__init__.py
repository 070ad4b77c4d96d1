"""The fast geometric world: boxes that rest on what is below them, no dynamics."""
