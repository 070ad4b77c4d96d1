"""What every result a command prints or writes has in common: floats to a few decimals, and
the checkpoint a policy came from named by path and SHA-256 (two files may hold the same
architecture: ``sage.pt`` and ``sage-seed0.pt`` are both ``gnn-sage``)."""

from __future__ import annotations

from pathlib import Path

from manigraph_shared.service_facts import checkpoint_of

#: Decimals a float keeps in a result: a success rate over 10,000 episodes still shows.
FLOAT_DIGITS = 4


def rounded(value: object, digits: int = FLOAT_DIGITS) -> object:
    """``value`` with every float in it (in dicts, lists and tuples, at any depth) rounded to
    ``digits`` decimals; everything else as it was."""
    if isinstance(value, float):
        return round(value, digits)
    if isinstance(value, dict):
        return {key: rounded(item, digits) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [rounded(item, digits) for item in value]
    return value


def checkpoint_field(policy: str | Path) -> dict[str, object]:
    """``{"checkpoint": {"path", "sha256"}}`` when ``policy`` is a file, else ``{}`` (a
    registered policy such as ``expert`` is named by its name alone)."""
    path = Path(policy)
    if not path.is_file():
        return {}
    checkpoint = checkpoint_of(path)
    return {"checkpoint": {"path": checkpoint.path, "sha256": checkpoint.sha256}}
