"""The training package's subcommand (``manigraph.commands`` entry point): ``commands/train.py``."""
