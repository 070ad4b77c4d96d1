"""The processes ``manigraph up`` runs on one machine: the router, the recorder, each robot
cell's sim, planner (or demonstration page) and skills, and perception of the rendered camera,
each as the ``manigraph`` command line and environment the supervisor starts it with."""

from __future__ import annotations

import argparse
import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

from manigraph_shared.bus_config import BusConfig
from manigraph_shared.errors import ConfigError
from manigraph_shared.manifest import driver_for_world, load_manifests
from manigraph_shared.options import option_argv
from manigraph_shared.registry import Registry
from manigraph_tools.access import CELL_SEPARATOR
from manigraph_tools.episodes import EpisodePlan
from manigraph_tools.family import family_of_task
from manigraph_tools.supervisor import ProcessSpec


def skills_driver(sim_backend: str) -> str:
    """The skills driver that needs only what the sim backend offers, from their manifests."""
    manifests = load_manifests()
    return driver_for_world(manifests["sim"], sim_backend, manifests["skills"])


def sim_backends() -> Registry[Any] | None:
    """The sim's backend registry, whose options ``up`` forwards to ``manigraph sim``; None
    where the sim is not installed (an image with one service, which cannot run ``up``)."""
    try:
        from manigraph_sim.backends import BACKENDS
    except ImportError:
        return None
    return BACKENDS


#: ``up --policy human``: no planner; the demonstration page (``manigraph demo-ui``) decides.
HUMAN = "human"
#: ``up --policy none``: no decider at all; a client of one's own plays the planner's part
#: (``examples/demonstrator.py``), and ``--record`` keeps its demonstrations.
NOBODY = "none"
#: ``up``'s default policy: the expert of the task's family (:func:`planner_policy`).
DEFAULT_EXPERT = "expert"


def demo_ui_argv(args: argparse.Namespace) -> list[str]:
    """``manigraph demo-ui`` flags from ``up``'s: the page's port and file, and the episode
    flags as the page's first episode."""
    from manigraph_tools.click_page.service import DemoUiOptions

    values = {
        "http_port": args.demo_port,
        "output": args.demo_output,
        "propose": args.propose,
        **{
            name: getattr(args, name)
            for name in ("task", "task_file", "blocks", "stacks", "objects", "preference", "seed")
        },
    }
    return ["demo-ui", *option_argv(DemoUiOptions, values)]


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


#: The same camera's colour and depth, no markers (the RGB-D pipeline).
SIM_RGBD_PERCEPTION = [
    "perception",
    "--pipeline",
    "rgbd",
    "--camera",
    "bus",
    "--calibration",
    SIM_CAMERA_PERCEPTION[-1],
]


def cell_specs(
    args: argparse.Namespace,
    plan: EpisodePlan | None,
    sim_options: list[str],
    human: bool,
    cell: str | None,
    spec: Callable[[str, list[str], dict[str, str]], ProcessSpec],
    with_planner: bool = True,
) -> list[ProcessSpec]:
    """The processes of one robot cell: its sim, planner (or demonstration page; no planner
    where one serves every cell) and skills, named ``sim@cell-1`` and so on where the cell is
    not the default."""
    where = {"MANIGRAPH_CELL": cell or ""}
    suffix = f"{CELL_MARK}{cell}" if cell else ""
    specs = [spec(f"sim{suffix}", ["sim", "--backend", args.sim, *sim_options], where)]
    if human:
        specs.append(spec(f"demo-ui{suffix}", demo_ui_argv(args), where))
    elif with_planner:
        specs.append(spec(f"planner{suffix}", planner_argv(args, plan), where))
    specs.append(spec(f"skills{suffix}", ["skills", "--driver", skills_driver(args.sim)], where))
    if args.scene_source == "camera":
        perception = [*SIM_CAMERA_PERCEPTION]
        markers = args.markers if args.markers == "sim" else str(Path(args.markers).resolve())
        perception[perception.index("--markers") + 1] = markers
        specs.append(spec(f"perception{suffix}", perception, where))
    elif args.scene_source == "rgbd":
        identity = ["--identity", args.rgbd_identity]
        specs.append(spec(f"perception{suffix}", [*SIM_RGBD_PERCEPTION, *identity], where))
    return specs


def planner_policy(args: argparse.Namespace) -> str:
    """The policy the planner plays: the one named, or for the default (``expert``) the expert
    of the task's family (its tools part's ``expert_of``; blocks and task files: ``expert``)."""
    if args.policy != DEFAULT_EXPERT or getattr(args, "task_file", None) is not None:
        return str(args.policy)
    family = family_of_task(args.task)
    return (
        args.policy if family is None or family.expert_of is None else family.expert_of(vars(args))
    )


def planner_argv(args: argparse.Namespace, plan: EpisodePlan | None) -> list[str]:
    planner = ["planner", "--policy", planner_policy(args)]
    if args.explain_decisions:
        planner.append("--explain-decisions")
    if args.accepts_filter == "off":
        planner += ["--accepts-filter", "off"]
    rules = getattr(args, "rules", None)  # a namespace of up's flags has it
    if rules is not None and args.policy == "expert":
        # The teacher is told the rules (the sim's judge gets them in every reset request).
        planner += ["--rules", str(Path(rules).resolve())]
    if plan is not None:
        # A decision may run as long as the run lets an episode go without news (a physics
        # PickAndPlace that turns a dish over first takes 20-60 s).
        planner += ["--decision-timeout", f"{plan.stall_timeout:g}"]
    return planner


#: Between a service and its cell in a process name: ``sim@cell-1``.
CELL_MARK = "@"


def service_of(process: str) -> str:
    return process.partition(CELL_MARK)[0]


#: The certificate CN of ``up``'s one planner for every cell (granted each of them).
SHARED_PLANNER = f"planner{CELL_SEPARATOR}shared"


def identity_of(process: str) -> str:
    """The TLS identity of a process: ``sim@cell-1`` presents ``sim.cell-1``."""
    service, _, cell = process.partition(CELL_MARK)
    return f"{service}{CELL_SEPARATOR}{cell}" if cell else service


def client_identity(client: BusConfig, cell: str | None) -> str | None:
    """The episode client of ``cell``: ``client.cell-1`` (granted that cell's resets only)."""
    if client.tls_identity is None or cell is None:
        return client.tls_identity
    return f"{client.tls_identity}{CELL_SEPARATOR}{cell}"


def in_cell(process: ProcessSpec, cell: str | None) -> bool:
    """Whether ``process`` belongs to ``cell`` (the router and recorder: the default cell)."""
    _, _, its_cell = process.name.partition(CELL_MARK)
    return (its_cell or None) == cell


def refuse_busy_port(port: int) -> None:
    """A second ``up`` on a port another stack's router holds would join that stack: its sim
    would answer the other's resets and both runs would be garbage. Refuse it instead."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as a router's listener
        try:
            probe.bind(("127.0.0.1", port))
        except OSError as exc:
            raise ConfigError(
                "port", f"127.0.0.1:{port} is in use ({exc.strerror}; another stack?): pass --port"
            ) from exc
