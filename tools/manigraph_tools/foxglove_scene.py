"""A ``Scene``, the latest ``Action`` and ``Explanation`` as one Foxglove ``SceneUpdate``.

What Foxglove's 3D panel draws, in the scene's frame:

* **blocks** as cubes of their size and orientation, each a colour of its own (from its id);
  **covers** as wooden plates; objects not visible now (inside a closed box) faded;
* **goals** as translucent cubes of the size of the objects they take, green when filled,
  orange when free, fainter when not visible now;
* **fixtures** of any kind (a rack, a board): a translucent cube of its size at its
  pose, or a small marker at its handle when it has no size, labelled with its kind and state;
  its metadata names its ``kind`` too;
* **boxes**: the contract has no box entity, so a box is drawn under every cover goal that
  stands above the table (a lid's place), as four walls with the covers' footprint, up to the
  lid;
* **the decision**: the latest ``Action`` of the episode as an arrow from the chosen object to
  the chosen goal;
* **the explanation**: the latest ``Explanation`` of the episode as lines between the nodes it
  kept, thicker and more opaque the more important the edge;
* **the emergency stop**: while one is engaged, a red ``ESTOP ENGAGED: <reason> (by <who>)``
  text above the scene (entity ``estop``), facing the camera.

Each update carries every entity (so the last message alone rebuilds the picture, as when
Foxglove seeks) and first deletes everything drawn before on the topic. Every entity's metadata
names the ``scene_sequence`` it shows.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Mapping

from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    KeyValuePair,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneEntityDeletion,
    SceneEntityDeletionType,
    SceneUpdate,
    TextPrimitive,
    Timestamp,
    Vector3,
)

from manigraph_shared.colours import colour_of, describe
from manigraph_shared.messages import (
    Action,
    EmergencyStop,
    Explanation,
    GoalCategory,
    ObjectCategory,
    Scene,
    SceneFixture,
    SceneGoal,
    SceneObject,
)
from manigraph_shared.messages import Quaternion as ContractQuaternion
from manigraph_shared.messages import Vector3 as ContractVector3

#: A block when the scene has none to measure (the tasks' 4 cm blocks).
DEFAULT_BLOCK_SIZE = (0.04, 0.04, 0.04)
#: A cover when the scene has none to measure (the box tasks' default cover).
DEFAULT_COVER_SIZE = (0.16, 0.16, 0.01)
#: A cover goal this high above the table is a lid's place: a box stands under it.
LID_MIN_HEIGHT = 0.02
#: Walls of a drawn box; the contract does not carry them, this is the tasks' default.
BOX_WALL = 0.01
#: Edges below this importance are not drawn.
MIN_EDGE_WEIGHT = 0.05

BLOCK_PALETTE = (
    (0.90, 0.30, 0.24),
    (0.20, 0.60, 0.86),
    (0.95, 0.77, 0.06),
    (0.56, 0.27, 0.68),
    (0.10, 0.74, 0.61),
    (0.90, 0.49, 0.13),
    (0.20, 0.29, 0.37),
    (0.91, 0.44, 0.65),
)
COVER = (0.72, 0.53, 0.32)
BOX = Color(r=0.55, g=0.45, b=0.35, a=0.6)
GOAL_FILLED = (0.18, 0.80, 0.25)
GOAL_FREE = (1.00, 0.55, 0.00)
FIXTURE = Color(r=0.60, g=0.62, b=0.66, a=0.35)
#: The edge of the marker drawn at a fixture with no size (at its handle), metres.
FIXTURE_MARKER = 0.03
ARROW = Color(r=0.85, g=0.10, b=0.85, a=1.0)
ESTOP = Color(r=0.95, g=0.05, b=0.05, a=1.0)
#: How far above an object or goal its label stands, metres.
LABEL_GAP = 0.015
#: Where the stop's text stands, above the scene's origin, metres.
ESTOP_TEXT_HEIGHT = 0.45
EDGE = (0.15, 0.45, 1.00)


def _point(v: ContractVector3) -> Point3:
    return Point3(x=v.x, y=v.y, z=v.z)


def _pose(position: tuple[float, float, float], orientation: ContractQuaternion) -> Pose:
    x, y, z = position
    q = orientation
    return Pose(
        position=Vector3(x=x, y=y, z=z),
        orientation=Quaternion(x=q.x, y=q.y, z=q.z, w=q.w),
    )


def block_colour(object_id: str, alpha: float) -> Color:
    """A colour of the block's own, the same for the same id in every scene and run."""
    r, g, b = BLOCK_PALETTE[zlib.crc32(object_id.encode()) % len(BLOCK_PALETTE)]
    return Color(r=r, g=g, b=b, a=alpha)


def _size_of(scene: Scene, category: ObjectCategory) -> tuple[float, float, float]:
    """The size of the scene's first object of ``category``, else a default: a cover's for
    covers, a block's for everything else (a dish slot with no dish of its kind left)."""
    for item in scene.objects:
        if item.category is category:
            return item.size.as_tuple()
    return DEFAULT_COVER_SIZE if category is ObjectCategory.COVER else DEFAULT_BLOCK_SIZE


class SceneEntities:
    """Builds the entities of one update; ``stamp`` and ``frame`` are the scene's."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.timestamp = Timestamp.from_epoch_secs(scene.stamp)
        self.metadata = [KeyValuePair(key="scene_sequence", value=str(scene.sequence))]
        self.entities: list[SceneEntity] = []

    def add(self, entity_id: str, **primitives: object) -> None:
        self.entities.append(
            SceneEntity(
                timestamp=self.timestamp,
                frame_id=self.scene.frame_id,
                id=entity_id,
                metadata=self.metadata,
                **primitives,  # type: ignore[arg-type]
            )
        )

    def objects(self) -> None:
        for item in self.scene.objects:
            alpha = 1.0 if item.visible else 0.35
            named = colour_of(item.attributes)
            if named is not None:  # the task's own colour (a colour-sort block is red)
                r, g, b = named
                colour = Color(r=r, g=g, b=b, a=alpha)
            elif item.category is ObjectCategory.COVER:
                r, g, b = COVER
                colour = Color(r=r, g=g, b=b, a=alpha)
            else:  # blocks and dishes: a colour of their own, stable per id
                colour = block_colour(item.id, alpha)
            texts = [self._label(item.position.as_tuple(), item.size.z, item.attributes)]
            self.add(
                f"object/{item.id}",
                cubes=[self._cube(item, colour)],
                texts=[t for t in texts if t is not None],
            )

    def _label(
        self,
        position: tuple[float, float, float],
        height: float,
        words: Mapping[str, object],
        prefix: str = "",
    ) -> TextPrimitive | None:
        """What the task tells an object by (``colour red``), or what a goal accepts, written
        just above it; None when there is nothing to say."""
        if not words:
            return None
        x, y, z = position
        return TextPrimitive(
            pose=_pose((x, y, z + height / 2 + LABEL_GAP), ContractQuaternion()),
            billboard=True,
            font_size=12.0,
            scale_invariant=True,
            color=Color(r=1.0, g=1.0, b=1.0, a=1.0),
            text=prefix + describe(words),
        )

    def _cube(self, item: SceneObject, colour: Color) -> CubePrimitive:
        x, y, z = item.size.as_tuple()
        return CubePrimitive(
            pose=_pose(item.position.as_tuple(), item.orientation),
            size=Vector3(x=x, y=y, z=z),
            color=colour,
        )

    def goals(self) -> None:
        # a goal takes the object category of its own name (block, cover, plate, bowl)
        sizes = {
            category: _size_of(self.scene, ObjectCategory(category.value))
            for category in GoalCategory
        }
        for goal in self.scene.goals:
            r, g, b = GOAL_FILLED if goal.filled else GOAL_FREE
            alpha = 0.3 if goal.visible else 0.12
            wanted = goal.accepts.get("size")
            # A goal that accepts one size is drawn that size (a size-sort row).
            x, y, z = wanted if isinstance(wanted, list) else sizes[goal.category]
            cube = CubePrimitive(
                pose=_pose(goal.position.as_tuple(), goal.orientation),
                size=Vector3(x=x, y=y, z=z),
                color=Color(r=r, g=g, b=b, a=alpha),
            )
            accepts = {k: v for k, v in goal.accepts.items() if k != "size"}
            label = self._label(goal.position.as_tuple(), z, accepts, "accepts ")
            self.add(f"goal/{goal.id}", cubes=[cube], texts=[label] if label else [])

    def fixtures(self) -> None:
        """Every fixture, whatever its family calls its kind: its own box, or a marker at its
        handle when the family gives it no size."""
        for fixture in self.scene.fixtures:
            size = fixture.size.as_tuple() if fixture.size else (FIXTURE_MARKER,) * 3
            cube = CubePrimitive(
                pose=_pose(fixture.position.as_tuple(), fixture.orientation),
                size=Vector3(x=size[0], y=size[1], z=size[2]),
                color=FIXTURE,
            )
            label = self._label(
                fixture.position.as_tuple(), size[2], {"kind": fixture.kind, **fixture.state}
            )
            self.entities.append(self._fixture_entity(fixture, cube, label))

    def _fixture_entity(
        self, fixture: SceneFixture, cube: CubePrimitive, label: TextPrimitive | None
    ) -> SceneEntity:
        return SceneEntity(
            timestamp=self.timestamp,
            frame_id=self.scene.frame_id,
            id=f"fixture/{fixture.id}",
            metadata=[*self.metadata, KeyValuePair(key="kind", value=fixture.kind)],
            cubes=[cube],
            texts=[label] if label else [],
        )

    def boxes(self) -> None:
        outer_x, outer_y, thickness = _size_of(self.scene, ObjectCategory.COVER)
        for goal in self.scene.goals:
            if goal.category is GoalCategory.COVER and goal.position.z > LID_MIN_HEIGHT:
                self.add(f"box/{goal.id}", cubes=self._walls(goal, outer_x, outer_y, thickness))

    def _walls(
        self, lid: SceneGoal, outer_x: float, outer_y: float, thickness: float
    ) -> list[CubePrimitive]:
        height = max(lid.position.z - thickness / 2, BOX_WALL)
        cx, cy = lid.position.x, lid.position.y
        upright = ContractQuaternion()
        walls = []
        for sign in (-1.0, 1.0):
            walls.append(((cx + sign * (outer_x - BOX_WALL) / 2, cy), (BOX_WALL, outer_y)))
            walls.append(((cx, cy + sign * (outer_y - BOX_WALL) / 2), (outer_x, BOX_WALL)))
        return [
            CubePrimitive(
                pose=_pose((x, y, height / 2), upright),
                size=Vector3(x=sx, y=sy, z=height),
                color=BOX,
            )
            for (x, y), (sx, sy) in walls
        ]

    def decision(self, action: Action) -> None:
        try:
            start = self.scene.object(action.object_id).position.as_tuple()
            end = self.scene.goal(action.goal_id).position.as_tuple()
        except KeyError:
            return  # a decision about entities this scene does not hold
        delta = tuple(e - s for s, e in zip(start, end, strict=True))
        length = math.sqrt(sum(d * d for d in delta))
        if length < 1e-6:
            return
        head = min(0.03, length / 2)
        arrow = ArrowPrimitive(
            pose=_pose(start, _x_towards(delta, length)),
            shaft_length=length - head,
            shaft_diameter=0.008,
            head_length=head,
            head_diameter=0.02,
            color=ARROW,
        )
        self.add("decision", arrows=[arrow])

    def explanation(self, explanation: Explanation) -> None:
        where = {node.id: node.position for node in explanation.nodes}
        lines = []
        for edge in explanation.edges:
            if edge.weight < MIN_EDGE_WEIGHT or edge.src not in where or edge.dst not in where:
                continue
            r, g, b = EDGE
            lines.append(
                LinePrimitive(
                    type=LinePrimitiveLineType.LineList,
                    thickness=0.002 + 0.01 * edge.weight,
                    points=[_point(where[edge.src]), _point(where[edge.dst])],
                    color=Color(r=r, g=g, b=b, a=0.2 + 0.8 * edge.weight),
                )
            )
        if lines:
            self.add("explanation", lines=lines)

    def stop(self, estop: EmergencyStop) -> None:
        """The engaged emergency stop, in words above the scene."""
        words = f"ESTOP ENGAGED: {estop.reason or 'no reason given'}"
        if estop.by:
            words += f" (by {estop.by})"
        text = TextPrimitive(
            pose=_pose((0.0, 0.0, ESTOP_TEXT_HEIGHT), ContractQuaternion()),
            billboard=True,
            font_size=24.0,
            scale_invariant=True,
            color=ESTOP,
            text=words,
        )
        self.add("estop", texts=[text])


def _x_towards(delta: tuple[float, ...], length: float) -> ContractQuaternion:
    """The rotation that turns the x axis (a Foxglove arrow's direction) onto ``delta``."""
    dx, dy, dz = (d / length for d in delta)
    # Half-way vector between x and the direction: q = (x cross d, 1 + x . d), normalised.
    w, x, y, z = 1.0 + dx, 0.0, -dz, dy
    norm = math.sqrt(w * w + y * y + z * z)
    if norm < 1e-9:  # pointing straight back along -x: half a turn about z
        return ContractQuaternion(x=0.0, y=0.0, z=1.0, w=0.0)
    return ContractQuaternion(x=x / norm, y=y / norm, z=z / norm, w=w / norm)


def scene_update(
    scene: Scene,
    action: Action | None = None,
    explanation: Explanation | None = None,
    estop: EmergencyStop | None = None,
) -> SceneUpdate:
    """Everything to draw for ``scene``; ``action`` and ``explanation`` only when they are
    about the scene's episode; ``estop`` (the latest stop or release) when it is engaged."""
    entities = SceneEntities(scene)
    entities.fixtures()
    entities.boxes()
    entities.goals()
    entities.objects()
    if action is not None and action.episode_id == scene.episode_id:
        entities.decision(action)
    if explanation is not None and explanation.episode_id == scene.episode_id:
        entities.explanation(explanation)
    if estop is not None and estop.engaged:
        entities.stop(estop)
    clear = SceneEntityDeletion(timestamp=entities.timestamp, type=SceneEntityDeletionType.All)
    return SceneUpdate(deletions=[clear], entities=entities.entities)
