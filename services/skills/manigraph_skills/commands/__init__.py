"""The skills service's subcommand (``manigraph.commands`` entry point): ``commands/skills.py``."""
