"""A bus client that tests and benches run *inside* a namespace (``ip netns exec NS python -m
manigraph_testkit.netprobe ...``): the test process itself lives outside every namespace.

``alive``: exit 0 once the named services are alive in the cell. ``listen``: record every
Scene, Action and RobotCommand of the cell (with arrival times) until SIGTERM or ``--seconds``,
then write them as JSON. ``forge``: publish ``--count`` robot commands into the cell under this
process's identity. The bus (router endpoint, TLS directory, identity) comes from the
``MANIGRAPH_*`` environment, as for every manigraph process.
"""

from __future__ import annotations

import argparse
import json
import signal
import threading
import time
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.messages import Action, GripperOp, RobotCommand, Scene, Vector3


def alive(bus: Bus, need: set[str], timeout: float) -> int:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if need <= bus.alive_services(timeout=1.0):
            return 0
        time.sleep(0.2)
    print(f"not alive after {timeout} s: {sorted(need - bus.alive_services(timeout=1.0))}")
    return 1


def listen(bus: Bus, seconds: float, out: Path) -> int:
    events: list[dict[str, object]] = []
    lock = threading.Lock()
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())

    def note(kind: str, **fields: object) -> None:
        with lock:
            events.append({"kind": kind, "at": time.time(), **fields})

    bus.subscribe(
        Scene,
        lambda s: note("scene", episode=s.episode_id, sequence=s.sequence, stamp=s.stamp),
    )
    bus.subscribe(
        Action,
        lambda a: note(
            "action", episode=a.episode_id, decision=a.decision_id, sequence=a.scene_sequence
        ),
    )
    bus.subscribe(
        RobotCommand,
        lambda c: note("command", command=c.command_id, decision=c.decision_id, op=str(c.op)),
    )
    Path(f"{out}.ready").write_text("ready")
    stop.wait(seconds)
    with lock:
        out.write_text(json.dumps(events))
    return 0


def forge(bus: Bus, count: int, tag: str) -> int:
    time.sleep(0.5)  # the session's declarations reach the router
    for index in range(count):
        bus.publish(
            RobotCommand(
                command_id=f"{tag}-{index}",
                decision_id=f"{tag}:{index}",
                op=GripperOp.PLACE,
                object_id=f"{tag}-object",  # no such object: a sim that gets it moves nothing
                position=Vector3(x=0.5, y=0.0, z=0.02),
                stamp=time.time(),
            )
        )
        time.sleep(0.05)
    time.sleep(0.5)
    return 0


def main() -> int:
    parser = argparse.ArgumentParser()
    add_bus_arguments(parser)
    parser.add_argument("what", choices=["alive", "listen", "forge"])
    parser.add_argument("--need", default="")
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--count", type=int, default=3)
    parser.add_argument("--tag", default="forged")
    args = parser.parse_args()
    with Bus.open(bus_config_from_args(args, wait_seconds=30.0)) as bus:
        if args.what == "alive":
            return alive(bus, set(args.need.split(",")), args.seconds)
        if args.what == "listen":
            return listen(bus, args.seconds, args.out)
        return forge(bus, args.count, args.tag)


if __name__ == "__main__":
    raise SystemExit(main())
