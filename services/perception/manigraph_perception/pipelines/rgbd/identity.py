"""Which layout object a detection is, the first time it is seen: by what it looks like.

Two modes (``IdentityMode``, ``manigraph perception --pipeline rgbd --identity``):

* ``appearance`` (the default): the layout's objects come **without positions**
  (``strip_positions``: every start is made unknown on the way in, whatever the sim or the
  file said), the goals with theirs. An object not yet found is given to a detection by a
  minimum-cost assignment (``min_cost_assignment``) on how unlike the layout's object it
  looks (``appearance_cost``): a named colour must be the detection's, the footprint must be
  the layout's size within the tracker's tolerance, and the rest (hue off the named colour,
  footprint and height off the size) is the cost. Objects that look the same are
  interchangeable: any assignment among them serves, and once found each is tracked by
  place (``tracker.py``) through occlusion and stacking, as in ``prior``.
* ``prior``: the old behaviour, for comparison. Every object is believed at the layout's
  starting position until seen, and matched by distance from that belief from the first
  frame on.
"""

from __future__ import annotations

import math
from enum import StrEnum

import msgspec
import numpy as np

from manigraph_shared.messages import TaskLayout, Vector3

#: The cost of a pair that is ruled out (a colour that differs, a footprint of another size):
#: large enough that a minimum-cost assignment takes one only where nothing else is left.
FORBIDDEN = 1e6


class IdentityMode(StrEnum):
    APPEARANCE = "appearance"
    PRIOR = "prior"


UNKNOWN = Vector3(x=math.nan, y=math.nan, z=math.nan)


def strip_positions(layout: TaskLayout) -> TaskLayout:
    """``layout`` with every object's starting position unknown (NaN: never on the wire;
    anything that still read one would get NaN, not a plausible place). Goals keep theirs."""
    objects = [msgspec.structs.replace(o, position=UNKNOWN) for o in layout.objects]
    return msgspec.structs.replace(layout, objects=objects)


def min_cost_assignment(cost: np.ndarray) -> list[tuple[int, int]]:
    """(row, column) pairs of least total cost, as many as the smaller side (the Hungarian
    method, O(n^2 m); n, m are tens at most). Pairs at ``FORBIDDEN`` or above are left out."""
    rows, cols = cost.shape
    if rows == 0 or cols == 0:
        return []
    transposed = rows > cols
    c = cost.T if transposed else cost
    n, m = c.shape
    u = np.zeros(n + 1)
    v = np.zeros(m + 1)
    p = np.zeros(m + 1, dtype=int)  # column j's row (1-based), 0: none
    way = np.zeros(m + 1, dtype=int)
    for i in range(1, n + 1):
        p[0] = i
        j0 = 0
        minv = np.full(m + 1, np.inf)
        used = np.zeros(m + 1, dtype=bool)
        while True:
            used[j0] = True
            i0 = p[j0]
            free = ~used[1:]
            reduced = c[i0 - 1] - u[i0] - v[1:]
            better = free & (reduced < minv[1:])
            minv[1:][better] = reduced[better]
            way[1:][better] = j0
            candidates = np.where(free, minv[1:], np.inf)
            j1 = int(np.argmin(candidates)) + 1
            delta = candidates[j1 - 1]
            u[p[used]] += delta
            v[used] -= delta
            minv[~used] -= delta
            j0 = j1
            if p[j0] == 0:
                break
        while j0 != 0:
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
    pairs = [(int(p[j]) - 1, j - 1) for j in range(1, m + 1) if p[j] != 0]
    if transposed:
        pairs = [(b, a) for a, b in pairs]
    return sorted((r, k) for r, k in pairs if cost[r, k] < FORBIDDEN)
