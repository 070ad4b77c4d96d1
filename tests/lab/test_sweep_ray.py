"""Sweeps on Ray: the same figures as the sequential run, failures named, bad clusters refused.

One local Ray of 2 CPUs serves the whole module (start-up takes seconds); the sweeps find it
already initialised and keep it open.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from manigraph_lab import ray_local
from manigraph_lab.demo_recording import DemoProtocol, record_demos
from manigraph_lab.generalization_suite import run_suite
from manigraph_lab.sweep import Job, SweepError, SweepOptions, run_jobs
from manigraph_planner.policies import load_policy
from manigraph_shared.cli import main
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError

pytestmark = pytest.mark.integration

#: A port where no Ray cluster listens (nothing may listen on port 1 without privileges).
NOWHERE = "127.0.0.1:1"


@pytest.fixture(scope="module")
def local_ray() -> Iterator[None]:
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    import ray

    with ray_local.local_ray(ray, 2, include_dashboard=False, log_to_driver=False):  # no /tmp/ray
        yield


@pytest.fixture(scope="module")
def demos(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    path = tmp_path_factory.mktemp("demos") / "demos.mcap"
    record_demos(load_policy("expert"), DemoProtocol(trajectories=4), path, None)
    return path.read_bytes()


@pytest.fixture
def one_thread() -> Iterator[None]:
    """The sequential reference at a Ray task's torch threads (1), so training matches."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def _suite(out: Path, demos: bytes, archs: list[str], sweep: SweepOptions) -> dict[str, object]:
    out.mkdir()
    (out / "demos.mcap").write_bytes(demos)
    return run_suite(out, archs, [0, 1], episodes=1, curve_episodes=0, epochs=1, sweep=sweep)


def test_ray_gives_the_sequential_figures(
    local_ray: None, demos: bytes, one_thread: None, tmp_path: Path
) -> None:
    alone = _suite(tmp_path / "sequential", demos, ["gcn"], SweepOptions(ray=False))
    on_ray = _suite(tmp_path / "ray", demos, ["gcn"], SweepOptions(workers=2))
    assert on_ray["results"] == alone["results"]
    rates = [r for cell in alone["results"]["gcn"].values() for r in cell]  # type: ignore[index]
    assert 0.0 < sum(rates) < len(rates)  # a mix of solved and failed cells: a real comparison
    tables = [(tmp_path / d / "generalization.md").read_text() for d in ("sequential", "ray")]
    assert tables[0] == tables[1]
    for seed in (0, 1):  # each training's checkpoint kept where a second run finds it
        assert (tmp_path / "ray" / "checkpoints" / f"gcn-seed{seed}.pt").stat().st_size > 0


def test_a_failing_cell_is_named_and_the_others_kept(
    local_ray: None, demos: bytes, tmp_path: Path
) -> None:
    with pytest.raises(SweepError) as info:
        _suite(tmp_path / "out", demos, ["gcn", "no-such-arch"], SweepOptions(workers=2))
    failures = info.value.failures
    assert "no-such-arch" in failures["no-such-arch seed 0: training"]
    assert failures["no-such-arch seed 1: 6-pyramid"] == (
        "not run: needs no-such-arch seed 1: training, which failed"
    )
    assert not any(name.startswith("gcn") for name in failures)
    written = json.loads((tmp_path / "out" / "suite.json").read_text())
    assert all(len(v) == 2 and None not in v for v in written["results"]["gcn"].values())
    assert all(v == [None, None] for v in written["results"]["no-such-arch"].values())
    assert "| no-such-arch | failed |" in (tmp_path / "out" / "generalization.md").read_text()


def test_an_unreachable_cluster_is_refused_naming_the_field(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as info:
        run_jobs([Job("a", abs, (-1,))], SweepOptions(ray_address=NOWHERE))
    assert info.value.field == "ray_address" and NOWHERE in str(info.value)


def test_the_command_refuses_a_bad_address_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status = main(["suite", "-o", str(tmp_path / "out"), "--ray-address", NOWHERE])
    assert status == CONFIG_EXIT_CODE
    assert "ray_address: no Ray cluster answers at 127.0.0.1:1" in capsys.readouterr().err
    assert not (tmp_path / "out" / "demos.mcap").exists()
