"""`manigraph up` as a user runs it: the whole stack, then Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from manigraph_shared.errors import CONFIG_EXIT_CODE
from manigraph_shared.mcap_log import read_log
from manigraph_shared.messages import Action, Explanation
from manigraph_shared.preflight import vulkan_problem
from manigraph_testkit.testing import free_port, run_up

CHECKPOINTS = Path(__file__).resolve().parents[2] / "checkpoints"

pytestmark = pytest.mark.integration


def children_of(pid: int) -> list[int]:
    result = subprocess.run(
        ["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True
    )
    return [int(p) for p in result.stdout.split()]


def ignore_sigint() -> None:
    """Start as a background job of a script does: with SIGINT ignored."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@pytest.mark.parametrize("stop_signal", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_stops_every_service_cleanly(stop_signal: int) -> None:
    up = subprocess.Popen(
        [sys.executable, "-m", "manigraph_shared.cli", "up", "--port", str(free_port())],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        preexec_fn=ignore_sigint,
    )
    assert up.stdout is not None
    lines = []
    deadline = time.monotonic() + 60
    for line in up.stdout:
        lines.append(line)
        if "stack is up" in line or time.monotonic() > deadline:
            break
    assert any("stack is up: router, sim, planner, skills" in line for line in lines), lines
    children = children_of(up.pid)
    assert len(children) == 4
    up.send_signal(stop_signal)
    rest, _ = up.communicate(timeout=30)
    assert up.returncode == 128 + stop_signal  # 130 for Ctrl-C, 143 for SIGTERM (running.md)
    for name in ("sim", "planner", "skills", "router"):
        assert f"{name:>10} | " in rest and "stopping" in rest
    for pid in children:
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


def test_explained_decisions_land_in_the_log_beside_the_decisions(tmp_path: Path) -> None:
    log = tmp_path / "explained.mcap"
    run_up(
        "--policy",
        str(CHECKPOINTS / "sage.pt"),
        "--blocks",
        "3",
        "--episodes",
        "1",
        "--explain-decisions",
        "--record",
        str(log),
    )
    decisions = [i for i in read_log(log) if i.topic == Action.key]
    explanations = [Explanation.decode(i.data) for i in read_log(log, [Explanation.key])]
    assert len(decisions) == 3
    assert sorted(e.decision_id for e in explanations) == sorted(
        Action.decode(i.data).decision_id for i in decisions
    )


@pytest.mark.parametrize("flag", [["--realtime"], ["--video", "clip.gif"]])
def test_physics_only_flags_are_refused_for_the_geometric_world(flag: list[str]) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "manigraph_shared.cli", "up", *flag, "--port", str(free_port())],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode != 0
    option = flag[0].lstrip("-")
    assert f"backend.{option}: not an option of backend 'geometric'" in result.stderr


def test_a_port_another_stack_holds_is_refused_before_anything_starts() -> None:
    """Two stacks on one router would answer each other's resets; the second is refused."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as other_stack:
        other_stack.bind(("127.0.0.1", 0))
        other_stack.listen()
        port = other_stack.getsockname()[1]
        result = subprocess.run(
            [sys.executable, "-m", "manigraph_shared.cli", "up", "--port", str(port)],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert result.returncode == CONFIG_EXIT_CODE
    assert f"port: 127.0.0.1:{port} is in use" in result.stderr
    assert "stack is up" not in result.stderr


def test_bad_options_are_named_before_a_busy_port() -> None:
    """Options the run cannot take are named whatever holds the port: a test of them once
    failed only because another stack was up on the default one."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as other_stack:
        other_stack.bind(("127.0.0.1", 0))
        other_stack.listen()
        port = other_stack.getsockname()[1]
        argv = ["up", "--policy", "human", "--episodes", "1", "--port", str(port)]
        result = subprocess.run(
            [sys.executable, "-m", "manigraph_shared.cli", *argv],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert result.returncode == CONFIG_EXIT_CODE
    assert "episodes: --policy human" in result.stderr and "in use" not in result.stderr


@pytest.mark.parametrize("json_only", [False, True])
def test_a_run_ends_with_one_json_line_and_says_it_in_words_unless_asked_not_to(
    json_only: bool,
) -> None:
    result = run_up("--blocks", "3", "--episodes", "2", *(["--json"] if json_only else []))
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["episodes"] == 2 and summary["success_rate"] == 1.0
    readable = "2 episodes of stack: success 1.000, goals filled 1.000"
    assert (readable in result.stderr) is not json_only


def test_a_task_file_with_spares_and_jitter_runs_under_its_own_name() -> None:
    example = CHECKPOINTS.parent / "examples" / "spares-and-jitter.toml"
    result = run_up("--task-file", str(example), "--episodes", "2", "--seed", "3")
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["task_file"] == "spares-and-jitter" and summary["name"] == "spares and jitter"
    assert summary["blocks"] == 5 and summary["success_rate"] == 1.0
    assert all(r["episode_id"].startswith("spares-and-jitter-") for r in summary["results"])
    assert "2 episodes of spares-and-jitter: success 1.000" in result.stderr
    assert "spares-and-jitter K=5 seed 3: success" in result.stderr


def test_the_camera_without_a_vulkan_device_is_refused_before_anything_starts() -> None:
    """VK_ICD_FILENAMES is the Vulkan loader's own override: naming no driver is a machine
    without one, as far as SAPIEN can tell."""
    started = time.monotonic()
    result = run_up(
        "--sim", "physics", "--scene-source", "camera", "--episodes", "1",
        env={"VK_ICD_FILENAMES": "/nonexistent/icd.json"}, check=False,
    )  # fmt: skip
    assert time.monotonic() - started < 10
    assert result.returncode == CONFIG_EXIT_CODE
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs a Vulkan device" in lines[0] and "make vulkan" in lines[0]


def test_a_missing_checkpoint_is_refused_before_anything_starts() -> None:
    result = run_up("--policy", "/nonexistent/sage.pt", "--episodes", "1", check=False)
    assert result.returncode == CONFIG_EXIT_CODE
    assert result.stderr.strip() == (
        "manigraph up: policy: no such checkpoint file: /nonexistent/sage.pt"
    )


def test_a_checkpoint_the_planner_cannot_read_stops_the_stack_without_restarts(
    tmp_path: Path,
) -> None:
    garbage = tmp_path / "garbage.pt"
    garbage.write_bytes(b"not a checkpoint")
    result = run_up("--policy", str(garbage), "--episodes", "1", check=False)
    # The planner refused its configuration: up exits as eval does with the same file.
    assert result.returncode == CONFIG_EXIT_CODE
    assert "not a manigraph checkpoint: " in result.stderr
    assert "planner refused its configuration" in result.stderr
    assert "restarting in" not in result.stderr


def test_a_marker_map_is_refused_without_the_camera_or_when_it_does_not_read(
    tmp_path: Path,
) -> None:
    result = run_up(
        "--markers", "examples/markers/colour-sort.toml", "--episodes", "1", check=False
    )
    assert result.returncode == CONFIG_EXIT_CODE
    assert "markers: only with --scene-source camera" in result.stderr
    bad = tmp_path / "markers.toml"
    bad.write_text("[[markers]]\nid = 0\nobject = 'block_0'\ncategory = 'plate'\nsize = 0.03\n")
    if vulkan_problem("the camera") is not None:
        pytest.skip("the camera check comes first without a Vulkan device")
    result = run_up(
        "--sim", "physics", "--scene-source", "camera", "--markers", str(bad), "--episodes", "1",
        check=False,
    )  # fmt: skip
    assert result.returncode == CONFIG_EXIT_CODE
    assert "markers.0.category" in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_no_decider_starts_no_planner_and_takes_no_episodes() -> None:
    """``--policy none``: a client of one's own decides (examples/demonstrator.py), so up
    runs no episodes of its own."""
    result = run_up("--policy", "none", "--episodes", "1", check=False)
    assert result.returncode == CONFIG_EXIT_CODE
    assert "--policy none: your own client starts each episode" in result.stderr
