"""`manigraph up`: the router and every service as supervised processes; with `--episodes`,
run them and exit."""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path

from manigraph_shared.bus import Bus
from manigraph_shared.bus_config import DEFAULT_PORT, BusConfig, loopback_endpoint
from manigraph_shared.cells import cell_names
from manigraph_shared.cli import Command
from manigraph_shared.errors import CONFIG_EXIT_CODE, ConfigError, ManigraphError
from manigraph_shared.markers import load_marker_map
from manigraph_shared.preflight import vulkan_problem
from manigraph_tools.access import cell_identities, write_cell_identities
from manigraph_tools.cell_episodes import run_cells
from manigraph_tools.certificates import IDENTITIES, make_certificates
from manigraph_tools.commands.common import emit_json
from manigraph_tools.commands.episode_flags import episode_arguments, plan_from_args
from manigraph_tools.episodes import raise_if_aborted, run_episodes
from manigraph_tools.owned_dir import OwnedDirectory
from manigraph_tools.stack_processes import (
    DEFAULT_EXPERT,
    HUMAN,
    NOBODY,
    SHARED_PLANNER,
    cell_specs,
    client_identity,
    identity_of,
    in_cell,
    planner_argv,
    refuse_busy_port,
    service_of,
    sim_backends,
)
from manigraph_tools.supervisor import STOP_SIGNALS, ProcessSpec, Supervisor
from manigraph_tools.up_guide import guide


class StackRefusedConfiguration(ManigraphError):
    """A service of the stack refused its configuration: ``up`` exits with that code too."""

    exit_code = CONFIG_EXIT_CODE


def _up_configure(parser: argparse.ArgumentParser) -> None:
    episode_arguments(parser)
    parser.add_argument("--record", type=Path, help="also record everything to this MCAP file")
    parser.add_argument(
        "--policy",
        default=DEFAULT_EXPERT,
        help="planner policy or checkpoint (default: the expert of the task's family); "
        f"'{HUMAN}': no planner, a person decides on the "
        f"demonstration page instead (docs/demo-ui.md); '{NOBODY}': no decider, a client of "
        "your own decides (examples/demonstrator.py)",
    )
    parser.add_argument(
        "--demo-port",
        type=int,
        default=8770,
        help=f"with --policy {HUMAN}: port of the demonstration page on 127.0.0.1 (default 8770)",
    )
    parser.add_argument(
        "--demo-output",
        type=Path,
        help=f"with --policy {HUMAN}: MCAP file of the demonstrations "
        "(default demos/demo-ui-<time>.mcap)",
    )
    parser.add_argument(
        "--propose",
        metavar="POLICY",
        help=f"with --policy {HUMAN}: this policy (name or checkpoint) proposes each decision on "
        "the page and the robot waits: one click accepts it, another pair corrects it, and "
        "both are recorded as demonstrations (docs/demo-ui.md)",
    )
    parser.add_argument(
        "--sim",
        default="geometric",
        choices=["geometric", "physics"],
        help="sim backend (default: geometric)",
    )
    parser.add_argument(
        "--scene-source",
        choices=["sim", "camera", "rgbd"],
        default="sim",
        help="who publishes Scene: the sim's ground truth (default) or perception reading "
        "the physics sim's rendered camera (needs Vulkan; docs/perception.md): its ArUco "
        "markers (camera) or its colour and depth, no markers (rgbd)",
    )
    parser.add_argument(
        "--rgbd-identity",
        choices=["appearance", "prior"],
        default="appearance",
        help="with --scene-source rgbd: appearance (default) finds each object by its colour "
        "and size, the layout's starting positions unused; prior matches by distance from "
        "them (the old behaviour, for comparison; docs/perception.md)",
    )
    parser.add_argument(
        "--markers",
        default="sim",
        help="with --scene-source camera: perception's marker map, a TOML file (ids of the "
        "sim's printed markers, with the objects' attributes, e.g. colours: "
        "examples/markers/colour-sort.toml; default: the sim's own map)",
    )
    parser.add_argument(
        "--explain-decisions",
        action="store_true",
        help="GNN policies: publish an Explanation beside every decision (lands in --record)",
    )
    parser.add_argument(
        "--accepts-filter",
        choices=["on", "off"],
        default="on",
        help="a GNN policy learned from a task file takes only pairs whose goal accepts the "
        "object (on, the default); off: the network's own choice (docs/training.md)",
    )
    parser.add_argument(
        "--cells",
        type=int,
        help="start N robot cells (cell-1 ... cell-N: each its own sim and skills under "
        "manigraph/<cell>/..., one planner serving them all) on one router; with --episodes "
        "each runs them on its own seeds and the JSON holds one success rate per cell "
        "(docs/scaling.md)",
    )
    parser.add_argument(
        "--planner-per-cell",
        action="store_true",
        help="with --cells: a planner process per cell instead of one for all (N copies of "
        "the policy and of torch; for comparison, docs/scaling.md)",
    )
    parser.add_argument(
        "--port",
        type=int,
        default=DEFAULT_PORT,
        help=f"router port on 127.0.0.1 (default {DEFAULT_PORT}); clients reach it with the "
        "same --port N, or with the -e line printed once the stack is up",
    )
    parser.add_argument(
        "--secure",
        action="store_true",
        help="mutual TLS and the router's access control, with certificates made for this run "
        "in a temporary directory (default: plain TCP on loopback, for development)",
    )
    parser.add_argument("--log-dir", type=Path, help="also write <service>.log files here")
    backends = sim_backends()
    if backends is not None:
        backends.add_arguments(
            parser.add_argument_group("sim backend options (passed to manigraph sim)")
        )


def _interrupt(signum: int, _frame: object) -> None:
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _up_run(args: argparse.Namespace) -> int:
    # Explicit handlers: a process started with SIGINT ignored (a background job of a script,
    # some CI runners) would otherwise never see Ctrl-C, and SIGTERM or a closing terminal
    # should stop it the same way. Once children run, the supervisor's handlers take over.
    for signum in STOP_SIGNALS:
        signal.signal(signum, _interrupt)
    backends = sim_backends()
    sim_options = (
        backends.argv(args.sim, backends.given_options(args)) if backends is not None else []
    )
    if args.task_file is not None:  # a reset for anything else is refused naming the file
        sim_options += ["--plays", str(args.task_file)]
    if args.scene_source in ("camera", "rgbd"):
        source = args.scene_source
        if args.sim != "physics":
            raise ConfigError("scene-source", f"{source} needs --sim physics (it renders)")
        problem = vulkan_problem(f"--scene-source {source} (the physics sim's rendered camera)")
        if problem:
            raise ConfigError("scene-source", problem)
        sim_options += ["--camera", "--no-scenes"]
        sim_options += ["--camera-depth"] if source == "rgbd" else []
    if args.rgbd_identity != "appearance" and args.scene_source != "rgbd":
        raise ConfigError("rgbd-identity", "only with --scene-source rgbd (perception uses it)")
    if args.markers != "sim":
        if args.scene_source != "camera":
            raise ConfigError("markers", "only with --scene-source camera (perception reads it)")
        load_marker_map(args.markers)  # a bad file is refused here, naming its field
    plan = plan_from_args(args, args.episodes) if args.episodes is not None else None
    human = args.policy == HUMAN
    if human and plan is not None:
        raise ConfigError(
            "episodes", f"--policy {HUMAN}: a person starts each episode on the page; leave it out"
        )
    if args.propose is not None and not human:
        raise ConfigError("propose", f"only with --policy {HUMAN}: the page shows the proposals")
    if args.policy == NOBODY and plan is not None:
        raise ConfigError(
            "episodes", f"--policy {NOBODY}: your own client starts each episode; leave it out"
        )
    if args.policy in (HUMAN, NOBODY) and args.explain_decisions:
        raise ConfigError("explain-decisions", f"needs a GNN planner, not --policy {args.policy}")
    if args.policy in (HUMAN, NOBODY) and args.accepts_filter == "off":
        raise ConfigError("accepts-filter", f"needs a GNN planner, not --policy {args.policy}")
    if args.policy.endswith(".pt") and not Path(args.policy).is_file():
        raise ConfigError("policy", f"no such checkpoint file: {args.policy}")
    if args.cells is not None and (args.policy in (HUMAN, NOBODY) or args.scene_source != "sim"):
        raise ConfigError("cells", f"one cell only with --policy {HUMAN} or --scene-source camera")
    if args.planner_per_cell and args.cells is None:
        raise ConfigError("planner-per-cell", "only with --cells")
    # The options first: a run refused for them names them, whatever else is on the port.
    refuse_busy_port(args.port)
    # Every private key of the stack: removed when up stops, and by a watcher should up be
    # killed (owned_dir: it does not outlive up, even SIGKILLed).
    certs = OwnedDirectory() if args.secure else None
    tls_dir = certs.path if certs is not None else None
    endpoint = loopback_endpoint(args.port, tls=tls_dir is not None)
    bus_env = {
        "MANIGRAPH_ZENOH_MODE": "client",
        "MANIGRAPH_ZENOH_CONNECT": endpoint,
        "MANIGRAPH_ZENOH_NO_MULTICAST_SCOUTING": "1",
        "MANIGRAPH_TLS_DIR": str(tls_dir or ""),  # plain TCP is chosen, not inherited
        "MANIGRAPH_TLS_IDENTITY": "",
    }
    cells: list[str | None] = [None] if args.cells is None else list(cell_names(args.cells))
    # One planner process for every cell (one torch, one copy of the policy), unless asked.
    shared_planner = args.cells is not None and not args.planner_per_cell
    if tls_dir is not None:
        # Each cell's processes present <service>.<cell>, granted that cell's keys only; the
        # shared planner presents planner.shared, granted every cell (docs/security.md).
        in_cells = cell_identities(str(cell) for cell in cells if cell)
        if shared_planner:
            in_cells[SHARED_PLANNER] = tuple(str(cell) for cell in cells)
        make_certificates(tls_dir, [*IDENTITIES, *in_cells], force=True)
        if in_cells:
            write_cell_identities(tls_dir, in_cells)

    def spec(name: str, argv: list[str], extra: dict[str, str] | None = None) -> ProcessSpec:
        identity = {"MANIGRAPH_TLS_IDENTITY": identity_of(name)} if tls_dir else {}
        return ProcessSpec(name, argv, {**bus_env, **identity, **(extra or {})})

    specs = [spec("router", ["router", "--listen", endpoint])]
    if args.record:
        specs.append(spec("recorder", ["record", "--output", str(args.record)]))
    for cell in cells:
        deciding = not shared_planner and args.policy != NOBODY
        specs += cell_specs(args, plan, sim_options, human, cell, spec, deciding)
    if shared_planner:
        served = ",".join(str(cell) for cell in cells)
        planner = spec("planner", [*planner_argv(args, plan), "--cells", served])
        if tls_dir is not None:
            planner.env["MANIGRAPH_TLS_IDENTITY"] = SHARED_PLANNER
        specs.append(planner)
    supervisor = Supervisor(args.log_dir)
    # A first signal stops the stack in order; a second one hurries the stop, never aborts it.
    supervisor.handle_signals()
    summary: dict[str, object] | None = None
    client = BusConfig(
        connect=(endpoint,),
        # The router is a process started just now: on a loaded 2-core machine its start took
        # 30-90 s (load 14-40). A router that dies stops the stack sooner anyway.
        wait_seconds=120.0,
        tls_dir=tls_dir,
        tls_identity="client" if tls_dir else None,
    )
    try:
        for process in specs:
            supervisor.start(process)
        supervisor.watch()  # a dead service is restarted; a dead router stops the stack
        with contextlib.ExitStack() as stack:
            buses = {
                cell: stack.enter_context(
                    Bus.open(replace(client, cell=cell, tls_identity=client_identity(client, cell)))
                )
                for cell in cells
            }
            # Services import torch and SAPIEN: 40-90 s each at load 15+ on two cores.
            for cell, bus in buses.items():
                names = [service_of(s.name) for s in specs if in_cell(s, cell)]
                if shared_planner:  # its token is in every cell it serves
                    names.append("planner")
                supervisor.wait_alive(bus, names, 180.0)
            security = "mutual TLS + access control" if tls_dir else "plain TCP"
            lines = guide(
                endpoint,
                tls_dir,
                [str(cell) for cell in cells if cell],
                next_steps=plan is None and not human,
            )
            print(
                "stack is up: " + ", ".join(s.name for s in specs) + f" ({security})",
                *lines,
                sep="\n",
                file=sys.stderr,
                flush=True,
            )
            if plan is None:
                if human:
                    print(
                        f"demonstration page: http://127.0.0.1:{args.demo_port}/",
                        file=sys.stderr,
                        flush=True,
                    )
                print("Ctrl-C stops every service", file=sys.stderr, flush=True)
                while True:
                    supervisor.raise_if_failed()
                    time.sleep(0.5)
            if args.cells is None:
                summary = run_episodes(buses[None], plan)
            else:
                summary = run_cells({str(c): bus for c, bus in buses.items()}, plan)
    except KeyboardInterrupt:
        if supervisor.failure is None:
            print("stopping the stack", file=sys.stderr)
    finally:
        supervisor.stop()
        supervisor.ignore_signals()  # up exits with the first signal's status, not a late one's
        if certs is not None:
            certs.remove()
    if supervisor.failure is not None:
        if supervisor.failure_is_configuration:  # exit as the refusal would in one process
            raise StackRefusedConfiguration(f"the stack stopped: {supervisor.failure}")
        raise ManigraphError(f"the stack stopped: {supervisor.failure}")
    if summary is not None:
        if any(supervisor.restarts.values()):
            summary["restarts"] = {k: v for k, v in supervisor.restarts.items() if v}
        emit_json(summary, readable=not args.json)
        # As `run` says it: an engaged stop (1), a planner that cannot decide (78), a cell's too
        raise_if_aborted(summary)
    if supervisor.stopped_by is not None:  # stopped as asked: exit as the signal says (130)
        raise KeyboardInterrupt(supervisor.stopped_by)
    return 0


command = Command(
    help="start the router and every service locally; with --episodes run them and exit",
    configure=_up_configure,
    run=_up_run,
)
