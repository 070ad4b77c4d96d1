"""The planner's subcommand (``manigraph.commands`` entry point): ``commands/planner.py``."""
