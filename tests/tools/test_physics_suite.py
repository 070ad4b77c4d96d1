"""bench/physics_suite.py: its cells are what issue 15 lists, spelled with flags that the
``manigraph run`` parser accepts, and its table shows what a run measured."""

from __future__ import annotations

import argparse
import importlib.util
import sys
from pathlib import Path

from manigraph_tools.commands.episode_flags import episode_arguments, plan_from_args

ROOT = Path(__file__).resolve().parents[2]


def _suite():
    spec = importlib.util.spec_from_file_location("physics_suite", ROOT / "bench/physics_suite.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["physics_suite"] = module
    spec.loader.exec_module(module)
    return module


def test_every_cell_parses_into_the_episodes_it_names() -> None:
    suite = _suite()
    parser = argparse.ArgumentParser()
    episode_arguments(parser)
    plans = {}
    for cell in suite.suite_cells():
        plan = plan_from_args(parser.parse_args(list(cell.args)), 20)
        plans[cell.name] = (plan.task, plan.blocks, plan.stacks)
    assert plans["multistack-3x3"] == ("multistack", 3, 3)  # 3 stacks of 3 blocks
    assert plans["pyramid-6"] == ("pyramid", 6, 1)
    assert {plans[f"stack-{k}"] for k in range(3, 10)} == {("stack", k, 1) for k in range(3, 10)}
    for task in ("box-pack", "box-unpack", "box-rearrangement"):
        assert plans[f"{task}-3"] == (task, 3, 1) and plans[f"{task}-4"] == (task, 4, 1)
    assert len(plans) == 15
    assert suite.run_order(suite.suite_cells())[0].name.startswith("box-rearrangement")


def test_the_table_shows_success_goals_time_and_refusals_and_lists_failures() -> None:
    suite = _suite()
    summary = {
        "episodes": 2,
        "success_rate": 0.5,
        "goals_filled_rate": 0.75,
        "mean_steps": 5.0,
        "mean_seconds": 1.25,
        "refusals": {"no_ik_solution": 2, "collision": 1},
        "results": [
            {
                "seed": 0,
                "success": True,
                "reason": "all goals filled",
                "goals_filled": 2,
                "goals_total": 2,
            },
            {
                "seed": 1,
                "success": False,
                "reason": "step budget spent",
                "goals_filled": 1,
                "goals_total": 2,
                "refusals": {"no_ik_solution": 2, "collision": 1},
            },
        ],
    }
    row = suite.cell_row(summary)
    refused = {"no_ik_solution": 2, "collision": 1}
    assert row["failed"] == [
        {"seed": 1, "reason": "step budget spent", "goals": "1/2", "refusals": refused}
    ]
    assert row["refusals"] == refused
    report = {
        "policies": {"sage": "x.pt", "gat": "y.pt"},
        "labels": {"stack-3": "stacking K=3"},
        "cells": {"stack-3": {"sage": row, "gat": {"error": "no summary"}}},
    }
    table = suite.markdown(report)
    shown = "| stacking K=3 | 1/2 (0.50) | 0.750 | 1.25 | 3 (no_ik_solution 2, collision 1) |"
    assert shown + " error | - | - | - |" in table
