"""The point-and-click demonstration page (``manigraph demo-ui``; docs/demo-ui.md)."""
