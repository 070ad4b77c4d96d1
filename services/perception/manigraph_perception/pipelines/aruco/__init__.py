"""Objects posed from the ArUco markers on them (docs/perception.md)."""
