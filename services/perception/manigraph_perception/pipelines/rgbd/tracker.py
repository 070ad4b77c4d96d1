"""Which layout object each detection is: identity over time without markers.

The layout names the objects (id, category, size, where each starts, and maybe a colour).
Each frame's detections are matched to them greedily, cheapest pair first, where a pair's cost
is the distance from where the object is believed to be (``WorldModel``: object permanence,
the carried-object rule) and a pair is ruled out when

* the colours differ: the layout's colour when it names one, else the hue the object showed
  when it was first matched (learned once per episode, from a match near its believed place
  or from a detection that no other object could be);
* the footprint differs from the layout's size by more than ``size_tolerance`` (a fully seen
  top only);
* the object is a covered detection's and it is further than ``covered_reach`` from its
  belief (a covered object's centre is rough: it is not evidence of a move).

An object with no detection keeps its belief (hidden under the blocks stacked on it, behind
the gripper, carried). A detection with no object is ignored (counted).

An object with no belief yet (``--identity appearance``: the layout gave no position) is
found by ``acquire``: a minimum-cost assignment of the detections no believed object took,
on how unlike the layout's object each looks (colour, size: ``identity.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manigraph_perception.pipelines.rgbd.identity import FORBIDDEN, min_cost_assignment
from manigraph_perception.pipelines.rgbd.objects import DetectedObject, palette_hues
from manigraph_perception.pipelines.rgbd.segment import hue_distance
from manigraph_shared.colours import COLOUR_KEYS
from manigraph_shared.messages import TaskLayout


@dataclass(frozen=True)
class TrackerConfig:
    #: Hue difference (OpenCV units, 2 degrees each) that makes two colours different.
    hue_tolerance: float = 6.0
    size_tolerance: float = 0.015
    covered_reach: float = 0.04
    #: A first match further than this from the believed place teaches no hue.
    learn_within: float = 0.03


class Tracker:
    def __init__(self, layout: TaskLayout, config: TrackerConfig | None = None) -> None:
        self.config = config or TrackerConfig()
        self.sizes = {o.id: np.array(o.size.as_tuple()) for o in layout.objects}
        self.colours: dict[str, str] = {}
        for o in layout.objects:
            for key in COLOUR_KEYS:
                value = o.attributes.get(key)
                if isinstance(value, str):
                    self.colours[o.id] = value.strip().lower()
        self.hues: dict[str, float] = {}
        self._named_hues = palette_hues(set(self.colours.values()))

    def acquire(
        self, detections: list[DetectedObject], unfound: list[str]
    ) -> list[tuple[str, DetectedObject]]:
        """(object id, detection) pairs for objects with no belief yet, by appearance alone:
        a minimum-cost assignment; each object found learns the hue it showed."""
        cost = np.array(
            [[self.appearance_cost(object_id, d) for d in detections] for object_id in unfound]
        ).reshape(len(unfound), len(detections))
        out = []
        for row, column in min_cost_assignment(cost):
            object_id, detection = unfound[row], detections[column]
            if object_id not in self.colours:
                self.hues[object_id] = detection.hue
            out.append((object_id, detection))
        return out

    def appearance_cost(self, object_id: str, detection: DetectedObject) -> float:
        """How unlike ``object_id`` (the layout's colour and size) the detection looks, in
        tolerances; ``FORBIDDEN`` where the colour differs or the footprint is another size.
        A covered detection shows no reliable footprint: its colour decides alone."""
        config = self.config
        cost = 0.0
        if object_id in self.colours:
            name = self.colours[object_id]
            if name != detection.colour:
                return FORBIDDEN
            if name in self._named_hues:
                cost += hue_distance(self._named_hues[name], detection.hue) / config.hue_tolerance
        if detection.covered:
            return cost + 1.0  # less sure than a top seen whole
        size = self.sizes[object_id]
        footprint = np.abs(np.sort(detection.size[:2]) - np.sort(size[:2]))
        if np.any(footprint > config.size_tolerance):
            return FORBIDDEN
        height = abs(float(detection.size[2]) - float(size[2]))
        return cost + float(footprint.sum() + height) / config.size_tolerance

    def match(
        self, detections: list[DetectedObject], believed: dict[str, np.ndarray]
    ) -> list[tuple[str, DetectedObject]]:
        """(object id, detection) pairs; ``believed``: object id -> believed centre."""
        pairs: list[tuple[float, str, int]] = []
        for index, detection in enumerate(detections):
            for object_id, position in believed.items():
                cost = self._cost(object_id, position, detection)
                if cost is not None:
                    pairs.append((cost, object_id, index))
        pairs.sort()
        # How many objects each detection could be: one only, and it teaches its hue.
        candidates = [0] * len(detections)
        for _, _, index in pairs:
            candidates[index] += 1
        taken_objects: set[str] = set()
        taken_detections: set[int] = set()
        out = []
        for cost, object_id, index in pairs:
            if object_id in taken_objects or index in taken_detections:
                continue
            taken_objects.add(object_id)
            taken_detections.add(index)
            detection = detections[index]
            if (
                object_id not in self.hues
                and object_id not in self.colours
                and (cost < self.config.learn_within or candidates[index] == 1)
            ):
                self.hues[object_id] = detection.hue
            out.append((object_id, detection))
        return out

    def _cost(
        self, object_id: str, position: np.ndarray, detection: DetectedObject
    ) -> float | None:
        config = self.config
        if object_id in self.colours and self.colours[object_id] != detection.colour:
            return None
        if object_id in self.hues and hue_distance(self.hues[object_id], detection.hue) > (
            config.hue_tolerance
        ):
            return None
        size = self.sizes[object_id]
        if not detection.covered:
            footprint = np.sort(detection.size[:2])
            if np.any(np.abs(footprint - np.sort(size[:2])) > config.size_tolerance):
                return None
        centre = detection.centre - np.array([0.0, 0.0, size[2] / 2])
        distance = float(np.linalg.norm(centre - position))
        if detection.covered and distance > config.covered_reach:
            return None
        return distance
