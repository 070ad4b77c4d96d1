"""The sim's subcommand (``manigraph.commands`` entry point): ``commands/sim.py``."""
