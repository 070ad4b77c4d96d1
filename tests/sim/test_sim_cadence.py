"""The sim service's cadence: a rate kept over time, no burst after a stall."""

from __future__ import annotations

from manigraph_sim.service import Cadence


def test_a_cadence_keeps_its_rate_when_checked_late_and_often() -> None:
    cadence = Cadence(30.0)
    # Checked every 5 ms (a physics step) for 10 s, a little late each time.
    due = sum(cadence.due(k * 0.005 + 0.001) for k in range(2000))
    assert 299 <= due <= 301


def test_a_cadence_does_not_burst_after_a_stall() -> None:
    cadence = Cadence(100.0)
    assert cadence.due(0.0)
    assert not cadence.due(0.005)
    assert cadence.due(2.0)  # two seconds late: one sample, then the rate again
    assert not cadence.due(2.001)
    assert cadence.due(2.011)
