"""The export formats ``manigraph export --format`` offers, one registry entry each.

An exporter is ``export(log, out, progress, cell) -> summary``: it reads robot cell ``cell``
of the MCAP ``log`` (``None``: the log's only cell; :func:`~.source.choose_cell`), writes into
the folder ``out`` (new, or empty), prints progress lines to ``progress`` and returns a
JSON-able summary of what it wrote. Entries are imported when chosen, so listing the formats
imports neither rosbags nor pyarrow.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TextIO

from manigraph_shared.registry import Registry

Exporter = Callable[[Path, Path, TextIO, str | None], dict[str, object]]

FORMATS: Registry[Exporter] = Registry("format")
FORMATS.add_lazy(
    "ros2",
    "manigraph_tools.interop.ros2_bag:export_ros2",
    help="a ROS 2 bag (MCAP storage, CDR, standard message types)",
)
FORMATS.add_lazy(
    "lerobot",
    "manigraph_tools.interop.lerobot_export:export_lerobot",
    help="a LeRobot dataset (v3 layout: parquet, episode metadata, info.json)",
)
