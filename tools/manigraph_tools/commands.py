"""The subcommands ``manigraph_shared`` registers: router, record, replay, doctor, keys, run, up."""

from __future__ import annotations

import argparse
import json
import shutil
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import BusConfig, add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError, ManigraphError
from manigraph_shared.manifest import driver_for_world, load_manifests
from manigraph_shared.mcap_log import LoggedMessage, recover_log
from manigraph_shared.messages import Action
from manigraph_shared.options import add_option_arguments, options_from_args
from manigraph_shared.registry import Registry
from manigraph_shared.service import run_service
from manigraph_tools import contract_doc, doctor
from manigraph_tools.certs import make_certificates
from manigraph_tools.episodes import EpisodeOptions, EpisodePlan, run_episodes
from manigraph_tools.recorder import DEFAULT_MAX_BYTES, DEFAULT_MAX_SECONDS, Recorder
from manigraph_tools.replay import ActionCheck, Replayer, recorded_actions
from manigraph_tools.router import run_router
from manigraph_tools.supervisor import ProcessSpec, Supervisor


def _emit_json(summary: dict[str, object], readable: bool = False) -> None:
    """The summary as one JSON line on stdout; with ``readable``, first a line for people on
    stderr."""
    if readable and "success_rate" in summary:
        print(
            f"{summary.get('episodes')} episodes of "
            f"{summary.get('task_file') or summary.get('task')}: "
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
    parser.add_argument(
        "--no-foxglove",
        action="store_true",
        help="only the JSON channels: no /foxglove/scene and /foxglove/tf",
    )
    parser.add_argument(
        "--max-bytes",
        type=int,
        default=DEFAULT_MAX_BYTES,
        help=f"start a new file past this size (default {DEFAULT_MAX_BYTES >> 20} MiB)",
    )
    parser.add_argument(
        "--max-seconds",
        type=float,
        default=DEFAULT_MAX_SECONDS,
        help=f"start a new file after this long (default {DEFAULT_MAX_SECONDS:g} s)",
    )
    parser.add_argument(
        "--recover",
        type=Path,
        metavar="FILE",
        help="finalise FILE, left unfinished by a killed recorder, in place; then exit",
    )
    add_bus_arguments(parser)


def _record_run(args: argparse.Namespace) -> int:
    if args.recover is not None:
        kept = recover_log(args.recover)
        print(f"{args.recover}: finalised with {kept} messages", file=sys.stderr)
        return 0
    return run_service(
        lambda bus: Recorder(
            bus,
            args.output,
            args.flush_interval,
            args.max_bytes,
            args.max_seconds,
            foxglove=not args.no_foxglove,
        ),
        bus_config_from_args(args),
    )


record_command = Command(
    help="record every manigraph/** sample to MCAP (flushed every 100 ms, rotated by size "
    "and age); --recover finalises a killed recorder's file",
    configure=_record_configure,
    run=_record_run,
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
    parser.add_argument(
        "--stall-seconds",
        type=float,
        default=doctor.DEFAULT_STALL_SECONDS,
        help="an alive service without a heartbeat for this long is STALLED "
        f"(default {doctor.DEFAULT_STALL_SECONDS:g}; 0: liveliness only)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    add_bus_arguments(parser)


def _doctor_run(args: argparse.Namespace) -> int:
    config = bus_config_from_args(args, wait_seconds=args.timeout)
    try:
        bus = Bus.open(config)
    except Exception as exc:  # no router at all: everything is missing
        print(f"cannot reach the bus ({config.describe()}): {exc}", file=sys.stderr)
        health = doctor.Health(list(args.expect), list(args.expect))
    else:
        with bus:
            health = doctor.check(bus, args.expect, args.timeout, args.stall_seconds)
    if args.json:
        _emit_json(health.as_json())
    else:
        print(doctor.table(health, args.expect))
    return 1 if doctor.unhealthy(health, args.expect) else 0


doctor_command = Command(
    help="list which services are alive, missing or stalled (exit 1 if any expected one is "
    "missing or stalled)",
    configure=_doctor_configure,
    run=_doctor_run,
)


# --- keys ---------------------------------------------------------------------------------------
def _keys_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--fields", action="store_true", help="also print every message's fields")
    parser.add_argument(
        "--flow", action="store_true", help="print the services' flow diagram (Mermaid) instead"
    )


def _keys_run(args: argparse.Namespace) -> int:
    if args.flow:
        print(contract_doc.flow_diagram())
        return 0
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
    add_option_arguments(parser.add_argument_group("episodes"), EpisodeOptions)


def _plan(args: argparse.Namespace, episodes: int) -> EpisodePlan:
    options = options_from_args(EpisodeOptions, args)
    return options.plan(episodes, run_id=f"{options.label()}-{int(time.time())}")


def _run_configure(parser: argparse.ArgumentParser) -> None:
    _episode_arguments(parser)
    add_bus_arguments(parser)


def _run_run(args: argparse.Namespace) -> int:
    plan = _plan(args, args.episodes or 1)  # a bad option stops here, before any waiting
    with Bus.open(bus_config_from_args(args, wait_seconds=30.0)) as bus:
        _wait_services(bus, ["sim", "planner", "skills"])
        summary = run_episodes(bus, plan)
    _emit_json(summary, readable=not args.json)
    return 0


run_command = Command(
    help="run seeded episodes on an already running stack; last line: one JSON object",
    configure=_run_configure,
    run=_run_run,
)


def _skills_driver(sim_backend: str) -> str:
    """The skills driver that needs only what the sim backend offers, from their manifests."""
    manifests = load_manifests()
    return driver_for_world(manifests["sim"], sim_backend, manifests["skills"])


def _sim_backends() -> Registry[Any] | None:
    """The sim's backend registry, whose options ``up`` forwards to ``manigraph sim``; None
    where the sim is not installed (an image with one service, which cannot run ``up``)."""
    try:
        from manigraph_sim.backends import BACKENDS
    except ImportError:
        return None
    return BACKENDS


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


def _up_configure(parser: argparse.ArgumentParser) -> None:
    _episode_arguments(parser)
    parser.add_argument("--record", type=Path, help="also record everything to this MCAP file")
    parser.add_argument("--policy", default="expert", help="planner policy or checkpoint")
    parser.add_argument(
        "--sim",
        default="geometric",
        choices=["geometric", "physics"],
        help="sim backend (default: geometric)",
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
    parser.add_argument(
        "--secure",
        action="store_true",
        help="mutual TLS and the router's access control, with certificates made for this run "
        "in a temporary directory (default: plain TCP on loopback, for development)",
    )
    parser.add_argument("--log-dir", type=Path, help="also write <service>.log files here")
    backends = _sim_backends()
    if backends is not None:
        backends.add_arguments(
            parser.add_argument_group("sim backend options (passed to manigraph sim)")
        )


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _up_run(args: argparse.Namespace) -> int:
    # Explicit handlers: a process started with SIGINT ignored (a background job of a script,
    # some CI runners) would otherwise never see Ctrl-C, and SIGTERM should stop it the same way.
    signal.signal(signal.SIGINT, _interrupt)
    signal.signal(signal.SIGTERM, _interrupt)
    tls_dir = Path(tempfile.mkdtemp(prefix="manigraph-certs-")) if args.secure else None
    endpoint = f"{'tls' if tls_dir else 'tcp'}/127.0.0.1:{args.port}"
    bus_env = {
        "MANIGRAPH_ZENOH_MODE": "client",
        "MANIGRAPH_ZENOH_CONNECT": endpoint,
        "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "1",
        "MANIGRAPH_TLS_DIR": str(tls_dir or ""),  # plain TCP is chosen, not inherited
        "MANIGRAPH_TLS_IDENTITY": "",
    }
    if tls_dir is not None:
        make_certificates(tls_dir, force=True)

    def spec(name: str, argv: list[str]) -> ProcessSpec:
        identity = {"MANIGRAPH_TLS_IDENTITY": name} if tls_dir else {}
        return ProcessSpec(name, argv, {**bus_env, **identity})

    backends = _sim_backends()
    sim_options = (
        backends.argv(args.sim, backends.given_options(args)) if backends is not None else []
    )
    if args.scene_source == "camera":
        if args.sim != "physics":
            raise ConfigError("scene-source", "camera needs --sim physics (it renders)")
        sim_options += ["--camera", "--no-scenes"]
    plan = _plan(args, args.episodes) if args.episodes is not None else None
    specs = [spec("router", ["router", "--listen", endpoint])]
    if args.record:
        specs.append(spec("recorder", ["record", "--output", str(args.record)]))
    specs += [
        spec("sim", ["sim", "--backend", args.sim, *sim_options]),
        spec(
            "planner",
            ["planner", "--policy", args.policy]
            + (["--explain-decisions"] if args.explain_decisions else []),
        ),
        spec("skills", ["skills", "--driver", _skills_driver(args.sim)]),
    ]
    if args.scene_source == "camera":
        specs.append(spec("perception", SIM_CAMERA_PERCEPTION))
    supervisor = Supervisor(args.log_dir)
    summary: dict[str, object] | None = None
    client = BusConfig(
        connect=(endpoint,),
        # The router is a fresh Python process: on a loaded 2-core machine its start alone took
        # 30-40 s (measured at load 14-18). A router that dies stops the stack sooner anyway.
        wait_seconds=120.0,
        tls_dir=tls_dir,
        tls_identity="client" if tls_dir else None,
    )
    try:
        for process in specs:
            supervisor.start(process)
        supervisor.watch()  # a dead service is restarted; a dead router stops the stack
        with Bus.open(client) as bus:
            # Services import torch and SAPIEN: 40-90 s each at load 15+ on two cores.
            supervisor.wait_alive(bus, [process.name for process in specs], timeout=180.0)
            security = "mutual TLS + access control" if tls_dir else "plain TCP"
            print(
                "stack is up: " + ", ".join(s.name for s in specs) + f" ({security})",
                file=sys.stderr,
                flush=True,
            )
            if plan is None:
                print("Ctrl-C stops every service", file=sys.stderr, flush=True)
                while True:
                    supervisor.raise_if_failed()
                    time.sleep(0.5)
            summary = run_episodes(bus, plan)
    except KeyboardInterrupt:
        if supervisor.failure is None:
            print("stopping the stack", file=sys.stderr)
    finally:
        supervisor.stop()
        if tls_dir is not None:
            shutil.rmtree(tls_dir, ignore_errors=True)
    if supervisor.failure is not None:
        raise ManigraphError(f"the stack stopped: {supervisor.failure}")
    if summary is not None:
        if any(supervisor.restarts.values()):
            summary["restarts"] = {k: v for k, v in supervisor.restarts.items() if v}
        _emit_json(summary, readable=not args.json)
    return 0


up_command = Command(
    help="start the router and every service locally; with --episodes run them and exit",
    configure=_up_configure,
    run=_up_run,
)
