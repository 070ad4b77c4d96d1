"""The helpers tests use to decide what the machine can give them."""

from __future__ import annotations

import multiprocessing
import os

from manigraph_testkit.testing import cpu_share, spare_core_problem


def _spin(seconds: float) -> None:
    import time

    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


def test_a_busy_machine_is_measured_as_such_and_named() -> None:
    """Spinning more processes than there are cores leaves a probe less than a core."""
    cores = os.cpu_count() or 1
    spinners = [multiprocessing.Process(target=_spin, args=(3.0,)) for _ in range(3 * cores)]
    for process in spinners:
        process.start()
    try:
        share = cpu_share(1.0)
        problem = spare_core_problem(need=0.99, seconds=1.0)
    finally:
        for process in spinners:
            process.join()
    assert share < 0.9
    assert problem is not None and "of a free core" in problem and "load" in problem


def test_a_share_is_a_fraction_of_one_core() -> None:
    assert 0.0 < cpu_share(0.2) <= 1.05
