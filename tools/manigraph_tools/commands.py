"""The subcommands ``manigraph_shared`` registers: router, record, replay, doctor, keys, run, up."""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError
from manigraph_shared.mcap_log import LoggedMessage
from manigraph_shared.messages import Action
from manigraph_shared.service import run_service
from manigraph_tools import contract_doc, doctor
from manigraph_tools.episodes import EpisodePlan, read_task_file, run_episodes
from manigraph_tools.recorder import Recorder
from manigraph_tools.replay import ActionCheck, Replayer, recorded_actions
from manigraph_tools.router import run_router
from manigraph_tools.supervisor import ProcessSpec, Supervisor


def _emit_json(summary: dict[str, object], readable: bool = False) -> None:
    """The summary as one JSON line on stdout; with ``readable``, first a line for people on
    stderr."""
    if readable and "success_rate" in summary:
        print(
            f"{summary.get('episodes')} episodes of {summary.get('task')}: "
            f"success {summary['success_rate']:.3f}, "
            f"goals filled {summary.get('goals_filled_rate', float('nan')):.3f}",
            file=sys.stderr,
            flush=True,
        )
    print(json.dumps(summary), flush=True)


# --- router -------------------------------------------------------------------------------------
def _router_configure(parser: argparse.ArgumentParser) -> None:
    add_bus_arguments(parser)


router_command = Command(
    help="run a Zenoh router (default: listen on tcp/127.0.0.1:7447)",
    configure=_router_configure,
    run=lambda args: run_router(bus_config_from_args(args, mode="router")),
)


# --- record -------------------------------------------------------------------------------------
def _record_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o", "--output", type=Path, default=Path("logs"), help="MCAP file or directory"
    )
    parser.add_argument("--flush-interval", type=float, default=0.1, help="seconds (default 0.1)")
    add_bus_arguments(parser)


record_command = Command(
    help="record every manigraph/** sample to MCAP (flushed every 100 ms)",
    configure=_record_configure,
    run=lambda args: run_service(
        lambda bus: Recorder(bus, args.output, args.flush_interval), bus_config_from_args(args)
    ),
)


# --- replay -------------------------------------------------------------------------------------
def _replay_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, help="MCAP log written by manigraph record")
    parser.add_argument("--speed", type=float, default=1.0, help="time scale (2 = twice as fast)")
    parser.add_argument("--loop", action="store_true", help="start over at the end until Ctrl-C")
    parser.add_argument("--topics", nargs="+", default=[], help="key patterns to publish")
    parser.add_argument("--exclude", nargs="+", default=[], help="key patterns to skip")
    parser.add_argument(
        "--expect-actions",
        action="store_true",
        help="withhold the recorded planner decisions and require a live planner to repeat them",
    )
    parser.add_argument(
        "--wait-for", nargs="*", default=None, help="services that must be alive before playing"
    )
    parser.add_argument(
        "--decision-timeout", type=float, default=5.0, help="seconds to wait for each decision"
    )
    add_bus_arguments(parser)


def _replay_run(args: argparse.Namespace) -> int:
    withhold = [Action.key] if args.expect_actions else []
    wait_for = (
        args.wait_for if args.wait_for is not None else (["planner"] if args.expect_actions else [])
    )
    with Bus.open(bus_config_from_args(args, wait_seconds=30.0)) as bus:
        check = ActionCheck(expected=recorded_actions(args.file) if args.expect_actions else {})
        if args.expect_actions:
            bus.subscribe(Action, check.receive)
        _wait_services(bus, wait_for)
        replayer = Replayer(bus, args.file, args.speed, args.topics, args.exclude, withhold)

        def await_live_decision(item: LoggedMessage) -> None:
            decision_id = Action.decode(item.data, item.topic).decision_id
            check.wait_for(decision_id, args.decision_timeout)

        stop = threading.Event()
        print(f"replaying {len(replayer.messages)} messages from {args.file}", file=sys.stderr)
        try:
            while True:
                replayer.play(stop, on_withheld=await_live_decision)
                if not args.loop:
                    break
        except KeyboardInterrupt:
            stop.set()
        if not args.expect_actions:
            return 0
        time.sleep(0.5)  # a decision the log does not have would arrive now
        problems = check.mismatches()
        for line in problems:
            print(f"MISMATCH {line}", file=sys.stderr)
        _emit_json(
            {
                "file": str(args.file),
                "decisions_expected": len(check.expected),
                "decisions_received": len(check.received),
                "mismatches": len(problems),
                "identical": not problems,
            }
        )
        return 0 if not problems else 1


def _wait_services(bus: Bus, names: list[str], timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while names and not set(names) <= bus.alive_services(timeout=1.0):
        if time.monotonic() > deadline:
            missing = set(names) - bus.alive_services()
            raise SystemExit(f"manigraph: services not alive: {sorted(missing)}")
        time.sleep(0.2)


replay_command = Command(
    help="publish a recorded MCAP log back onto the bus with its original timing",
    configure=_replay_configure,
    run=_replay_run,
)


# --- doctor -------------------------------------------------------------------------------------
def _doctor_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--expect",
        nargs="+",
        default=list(doctor.DEFAULT_STACK),
        help=f"services that must be alive (default: {' '.join(doctor.DEFAULT_STACK)})",
    )
    parser.add_argument("--timeout", type=float, default=2.0, help="seconds to wait for answers")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_bus_arguments(parser)


def _doctor_run(args: argparse.Namespace) -> int:
    config = bus_config_from_args(args, wait_seconds=args.timeout)
    try:
        bus = Bus.open(config)
    except Exception as exc:  # no router at all: everything is missing
        print(f"cannot reach the bus ({config.describe()}): {exc}", file=sys.stderr)
        names, missing = list(args.expect), list(args.expect)
    else:
        with bus:
            names, missing = doctor.check(bus, args.expect, args.timeout)
    if args.json:
        _emit_json({"alive": [n for n in names if n not in missing], "missing": missing})
    else:
        print(doctor.table(names, missing, args.expect))
    return 1 if missing else 0


doctor_command = Command(
    help="list which services are alive and which are missing (exit 1 if any is missing)",
    configure=_doctor_configure,
    run=_doctor_run,
)


# --- keys ---------------------------------------------------------------------------------------
def _keys_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fields", action="store_true", help="also print every message's fields")


def _keys_run(args: argparse.Namespace) -> int:
    print(contract_doc.key_table())
    if args.fields:
        print()
        print(contract_doc.field_tables())
    return 0


keys_command = Command(
    help="print the key expression / message table (Markdown, as in the README)",
    configure=_keys_configure,
    run=_keys_run,
)


# --- run / up -----------------------------------------------------------------------------------
def _episode_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("episodes")
    group.add_argument("--task", default="stack", help="task name (default: stack)")
    group.add_argument("--task-file", type=Path, help="a TOML layout of your own (see README)")
    group.add_argument("--blocks", type=int, default=4, help="blocks per stack K (default 4)")
    group.add_argument("--stacks", type=int, default=1, help="number of stacks s (default 1)")
    group.add_argument("--episodes", type=int, default=None, help="run N episodes, then exit")
    group.add_argument("--seed", type=int, default=0, help="seed of the first episode")
    group.add_argument("--timeout", type=float, default=120.0, help="seconds per episode")
    group.add_argument(
        "--json", action="store_true", help="print only the JSON summary (stdout, one line)"
    )


def _plan(args: argparse.Namespace, episodes: int) -> EpisodePlan:
    task_file = read_task_file(args.task_file)
    return EpisodePlan(
        task="file" if task_file is not None else args.task,
        task_file=task_file,
        blocks=args.blocks,
        stacks=args.stacks,
        episodes=episodes,
        seed=args.seed,
        timeout=args.timeout,
        run_id=f"{args.task}-{args.blocks}-{int(time.time())}",
    )


def _run_configure(parser: argparse.ArgumentParser) -> None:
    _episode_arguments(parser)
    add_bus_arguments(parser)


def _run_run(args: argparse.Namespace) -> int:
    with Bus.open(bus_config_from_args(args, wait_seconds=30.0)) as bus:
        _wait_services(bus, ["sim", "planner", "skills"])
        summary = run_episodes(bus, _plan(args, args.episodes or 1))
    _emit_json(summary, readable=not args.json)
    return 0


run_command = Command(
    help="run seeded episodes on an already running stack; last line: one JSON object",
    configure=_run_configure,
    run=_run_run,
)


#: The robot driver the skills service needs for each sim backend: the geometric world takes
#: Cartesian gripper commands, the physics Panda joint trajectories planned by the skills.
SKILLS_DRIVER_FOR_SIM = {"geometric": "sim-gripper", "physics": "panda-sim"}


#: Perception of the physics sim's rendered camera: its markers and exact calibration.
SIM_CAMERA_PERCEPTION = [
    "perception",
    "--camera",
    "bus",
    "--markers",
    "sim",
    "--calibration",
    str(Path(__file__).resolve().parents[2] / "examples" / "calibration" / "sim-front.yaml"),
]


def _sim_args(args: argparse.Namespace) -> list[str]:
    extra: list[str] = []
    if args.video is not None:
        if args.sim != "physics":
            raise ConfigError("video", "needs --sim physics")
        extra += ["--video", str(args.video.resolve())]
    if args.realtime:
        if args.sim != "physics":
            raise ConfigError("realtime", "needs --sim physics")
        extra.append("--realtime")
    if args.scene_source == "camera":
        if args.sim != "physics":
            raise ConfigError("scene-source", "camera needs --sim physics (it renders)")
        extra += ["--camera", "--no-scenes"]
    if args.box_geometry is not None:
        if args.sim != "geometric":
            raise ConfigError("box-geometry", "the physics world always has its own boxes")
        extra += ["--box-geometry", args.box_geometry]
    return extra


def _up_configure(parser: argparse.ArgumentParser) -> None:
    _episode_arguments(parser)
    parser.add_argument("--record", type=Path, help="also record everything to this MCAP file")
    parser.add_argument("--policy", default="expert", help="planner policy or checkpoint")
    parser.add_argument(
        "--sim",
        default="geometric",
        choices=sorted(SKILLS_DRIVER_FOR_SIM),
        help="sim backend (default: geometric)",
    )
    parser.add_argument(
        "--video", type=Path, help="physics: render episodes to this .gif/.mp4 (needs Vulkan)"
    )
    parser.add_argument(
        "--realtime", action="store_true", help="physics: simulate in real time, not flat out"
    )
    parser.add_argument(
        "--box-geometry",
        choices=["geometric", "physics"],
        help="geometric sim: lay box tasks out with this geometry (physics: the physics "
        "world's, to compare both worlds on the same layouts)",
    )
    parser.add_argument(
        "--scene-source",
        choices=["sim", "camera"],
        default="sim",
        help="who publishes Scene: the sim's ground truth (default) or perception reading "
        "the physics sim's rendered camera (needs Vulkan; docs/perception.md)",
    )
    parser.add_argument(
        "--explain-decisions",
        action="store_true",
        help="GNN policies: publish an Explanation beside every decision (lands in --record)",
    )
    parser.add_argument("--port", type=int, default=7447, help="router port on 127.0.0.1")
    parser.add_argument("--log-dir", type=Path, help="also write <service>.log files here")


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _up_run(args: argparse.Namespace) -> int:
    # Explicit handlers: a process started with SIGINT ignored (a background job of a script,
    # some CI runners) would otherwise never see Ctrl-C, and SIGTERM should stop it the same way.
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    endpoint = f"tcp/127.0.0.1:{args.port}"
    bus_env = {
        "MANIGRAPH_ZENOH_MODE": "client",
        "MANIGRAPH_ZENOH_CONNECT": endpoint,
        "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "1",
    }
    specs = [ProcessSpec("router", ["router", "--listen", endpoint])]
    if args.record:
        specs.append(ProcessSpec("recorder", ["record", "--output", str(args.record)], bus_env))
    specs += [
        ProcessSpec("sim", ["sim", "--backend", args.sim, *_sim_args(args)], bus_env),
        ProcessSpec(
            "planner",
            ["planner", "--policy", args.policy]
            + (["--explain-decisions"] if args.explain_decisions else []),
            bus_env,
        ),
        ProcessSpec("skills", ["skills", "--driver", SKILLS_DRIVER_FOR_SIM[args.sim]], bus_env),
    ]
    if args.scene_source == "camera":
        specs.append(ProcessSpec("perception", SIM_CAMERA_PERCEPTION, bus_env))
    supervisor = Supervisor(args.log_dir)
    summary: dict[str, object] | None = None
    try:
        for spec in specs:
            supervisor.start(spec)
        with Bus.open(
            bus_config_from_args(
                argparse.Namespace(connect=[endpoint], no_multicast_scouting=True),
                wait_seconds=30.0,
            )
        ) as bus:
            supervisor.wait_alive(bus, [spec.name for spec in specs])
            print("stack is up: " + ", ".join(s.name for s in specs), file=sys.stderr, flush=True)
            if args.episodes is None:
                print("Ctrl-C stops every service", file=sys.stderr, flush=True)
                while True:
                    supervisor.raise_if_dead()
                    time.sleep(0.5)
            summary = run_episodes(bus, _plan(args, args.episodes))
    except KeyboardInterrupt:
        print("stopping the stack", file=sys.stderr)
    finally:
        supervisor.stop()
    if summary is not None:
        _emit_json(summary, readable=not args.json)
    return 0


up_command = Command(
    help="start the router and every service locally; with --episodes run them and exit",
    configure=_up_configure,
    run=_up_run,
)
