"""manigraph's planner: GNN policies, their training and their explanations.

PyG scripts a few helpers with ``torch.jit.script`` when it is imported, and torch (2.9 on) warns
on each call that ``torch.jit.script`` is deprecated: a warning no user of manigraph can act
on (manigraph never scripts), so it is silenced here, before any module imports PyG. Every
other warning still shows.
"""

import warnings

warnings.filterwarnings(
    "ignore", message=r"`torch\.jit\.script` is deprecated", category=FutureWarning
)
