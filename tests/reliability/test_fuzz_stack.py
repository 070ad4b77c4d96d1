"""A real stack (router, sim, planner, skills as processes) takes thousands of malformed
fuzzed payloads on every key of the contract (2,000 per published type, 400 per query type),
then still runs a 4-block episode to success; nothing died and every service counted them."""

from __future__ import annotations

import json
import time

import pytest

from manigraph_shared.messages import ServiceStatus
from manigraph_testkit.flood import fuzz_stack
from manigraph_testkit.testing import Stack

pytestmark = pytest.mark.integration

PER_TYPE = 2000
SERVICES = ("sim", "planner", "skills")


def test_fuzzed_payloads_on_every_key_leave_the_stack_working(running_stack: Stack) -> None:
    running_stack.start("router")
    for name in SERVICES:
        running_stack.start(name, name)
    beats: dict[str, ServiceStatus] = {}
    with running_stack.client() as bus:
        running_stack.wait_alive(bus, "router", *SERVICES, timeout=120)
        bus.subscribe(
            ServiceStatus,
            lambda status: beats.__setitem__(status.service, status),
            on_error=lambda _error: None,  # our own fuzz on manigraph/status/fuzz
        )
        counts = fuzz_stack(bus, PER_TYPE, seed=16, valid_share=0.0)
        assert all(count.sent >= PER_TYPE * 0.2 for count in counts.values())
        assert sum(count.sent for count in counts.values()) > 20_000
        time.sleep(2.0)  # a heartbeat after the last payload
        for name, process in running_stack.processes.items():
            assert process.poll() is None, f"{name} died:\n{running_stack.log(name)[-3000:]}"
        assert {s for s in SERVICES if beats[s].messages_rejected > 100} == set(SERVICES)
    result = running_stack.run("run", "--blocks", "4", "--episodes", "1", "--json", timeout=120)
    assert result.returncode == 0, result.stderr[-3000:]
    assert json.loads(result.stdout.strip().splitlines()[-1])["success_rate"] == 1.0
    doctor = running_stack.run("doctor", "--json")
    assert doctor.returncode == 0, doctor.stdout
