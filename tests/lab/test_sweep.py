"""The sweep runner's sequential path and its options (no Ray started here)."""

from __future__ import annotations

import argparse

import pytest

from manigraph_lab.sweep import (
    Job,
    Needs,
    SweepOptions,
    add_sweep_options,
    run_jobs,
)
from manigraph_shared.errors import ConfigError


def _double(x: int) -> int:
    return 2 * x


def _fail(x: int) -> int:
    raise RuntimeError(f"cell broke on {x}")


def _parse(*argv: str) -> SweepOptions:
    parser = argparse.ArgumentParser()
    add_sweep_options(parser)
    return SweepOptions.from_args(parser.parse_args(list(argv)))


def test_jobs_run_in_order_with_their_inputs_and_a_failure_named() -> None:
    jobs = [
        Job("a", _double, (1,)),
        Job("b", _fail, (2,)),
        Job("c", _double, (Needs("a"),)),
        Job("d", _double, (Needs("b"),)),
    ]
    outcomes = run_jobs(jobs, SweepOptions(ray=False))
    assert [o.value for o in outcomes] == [2, None, 4, None]
    assert outcomes[1].error == "RuntimeError: cell broke on 2"
    assert outcomes[3].error == "not run: needs b, which failed"


def test_job_names_are_unique_and_inputs_come_first() -> None:
    with pytest.raises(ValueError, match="repeat"):
        run_jobs([Job("a", _double, (1,)), Job("a", _double, (2,))], SweepOptions(ray=False))
    with pytest.raises(ValueError, match="not an earlier job"):
        run_jobs([Job("a", _double, (Needs("b"),))], SweepOptions(ray=False))


def test_command_line_chooses_ray_unless_one_local_worker_or_no_ray() -> None:
    assert _parse().ray and _parse().workers is None
    assert _parse("--workers", "2").ray and _parse("--workers", "2").task_threads == 1
    assert not _parse("--workers", "1").ray
    assert not _parse("--no-ray").ray
    joined = _parse("--workers", "1", "--ray-address", "10.0.0.5:6379")
    assert joined.ray and joined.task_threads == 1


@pytest.mark.parametrize(
    ("argv", "field"),
    [
        (["--workers", "0"], "workers"),
        (["--ray-address", "nowhere"], "ray_address"),
        (["--ray-address", "host:99999"], "ray_address"),
        (["--ray-address", "10.0.0.5:6379", "--no-ray"], "ray_address"),
    ],
)
def test_bad_options_name_their_field(argv: list[str], field: str) -> None:
    with pytest.raises(ConfigError) as info:
        _parse(*argv)
    assert info.value.field == field
