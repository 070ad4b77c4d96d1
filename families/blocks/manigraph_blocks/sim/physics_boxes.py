"""The box tasks' geometry in the physics world: room for the Panda's fingers.

The geometric world's 3 x 3 grid leaves 5 mm between blocks; the Panda's open fingers reach
``FINGER_REACH`` (6.6 cm) out from the TCP, so a finger fits between a block and its neighbour
only if their centres are ``BLOCK_SIZE / 2 + FINGER_REACH`` plus a clearance apart. The
physics grid is therefore narrow along x and wide along y:

* along x (``NARROW_PITCH``) blocks stand 1 cm apart and the fingers never go between them;
* along y (``WIDE_PITCH``) a finger fits between neighbours.

The skills close the fingers along the axis with room (``manigraph_skills.grasp_choice``):
with the grid's first four cells (centre, -x, -y, +y) every pick and place of box packing and
unpacking has such an axis, and the box is wide enough that a lone block can be grasped along
x at the -x cell. The first four cells are all this geometry supports (``max_blocks``): a
fifth, in a corner, has a neighbour or a wall on both axes.

The rim is 5 cm high so the hand (its underside 3.7 cm above the TCP) passes over it when the
TCP is at a block's centre. Sites are squares of the cover's side plus a centimetre that never
overlap, in an area where the Panda reaches every cell top-down (the far corner of the grid
within ~0.77 m of the base, the nearest 0.30 m in front of it).
"""

from __future__ import annotations

from manigraph_blocks.sim.box_geometry import BoxGeometry
from manigraph_shared.panda import FINGER_REACH
from manigraph_sim.world_model import BLOCK_SIZE

#: Between a finger and whatever it passes, metres.
CLEARANCE = 0.009
NARROW_PITCH = BLOCK_SIZE + 0.01
WIDE_PITCH = BLOCK_SIZE / 2 + FINGER_REACH + CLEARANCE
#: A lone block at the -x cell is grasped along x: the -x wall must clear the finger.
INNER = 2 * (NARROW_PITCH + FINGER_REACH + CLEARANCE)
WALL = 0.01

PHYSICS_BOXES = BoxGeometry(
    inner=INNER,
    wall=WALL,
    height=0.05,
    cover_thickness=0.01,
    pitch=(NARROW_PITCH, WIDE_PITCH),
    site_distance=INNER + 2 * WALL + 0.01,
    square_sites=True,
    site_x=(0.35, 0.66),
    site_y=(-0.30, 0.30),
    max_blocks=4,
)
