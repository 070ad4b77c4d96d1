"""manigraph lab: offline tools that run the sim and planner logic in one process."""
