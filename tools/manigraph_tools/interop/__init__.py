"""Interop: manigraph's logs as other ecosystems' formats (ROS 2 bags, LeRobot datasets) and
its bus in ROS 2's own wire format (``rmw_zenoh``). docs/interop.md."""
