"""``manigraph explain``: ask the running planner why it decided (or explain a logged decision
offline), print it, draw it; ``manigraph explain-study``: the paper's Table "gnn"."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from manigraph_shared.bus_config import add_bus_arguments, bus_config_from_args
from manigraph_shared.cli import Command
from manigraph_shared.errors import ConfigError, LogError
from manigraph_shared.messages import (
    EXPLAINER_BUSY,
    EXPLAINER_WARMING_UP,
    Action,
    ExplainRequest,
    Explanation,
    Scene,
)


def _configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--decision", help="decision id to explain (default: the latest)")
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the mask optimisation; with --summary, of the first episode (default 0)",
    )
    parser.add_argument("--json", action="store_true", help="last line: one JSON object")
    parser.add_argument("--png", type=Path, help="also draw the explanation to this PNG file")
    parser.add_argument("--timeout", type=float, default=4.0, help="seconds to wait (default 4)")
    offline = parser.add_argument_group("offline (no running stack)")
    offline.add_argument("--checkpoint", type=Path, help="GNN checkpoint to explain")
    offline.add_argument(
        "--scene-from", type=Path, help="MCAP log: explain its decision --decision (or the last)"
    )
    learned = parser.add_argument_group(
        "what was learned (--summary; no running stack, docs/explainer.md)"
    )
    learned.add_argument(
        "--summary",
        action="store_true",
        help="play --episodes scenes of --task-file in-process and print, per attribute value, "
        "the goals --policy sends those objects to, and how often (with --rules: agreement)",
    )
    learned.add_argument("--policy", help="with --summary: policy name or checkpoint file")
    learned.add_argument("--task-file", type=Path, help="with --summary: the task file to play")
    learned.add_argument(
        "--rules",
        type=Path,
        help="with --summary: rules file to judge the placements by (the policy never sees it; "
        "the expert teacher is told it)",
    )
    learned.add_argument(
        "--episodes", type=int, default=20, help="with --summary: scenes to play (default 20)"
    )
    learned.add_argument(
        "--accepts-filter",
        choices=["on", "off"],
        default="on",
        help="with --summary: a task policy's accepts filter (default on; docs/training.md)",
    )
    add_bus_arguments(parser)


_SUMMARY_ONLY = ("policy", "task_file", "rules")


def _run(args: argparse.Namespace) -> int:
    if args.seed < 0:
        raise ConfigError("seed", "must be >= 0")
    if args.summary:
        from manigraph_lab.explain_summary import run_summary

        return run_summary(args)
    for name in _SUMMARY_ONLY:
        if getattr(args, name) is not None:
            flag = "--" + name.replace("_", "-")
            raise ConfigError(name, f"{flag} goes with --summary (what a policy learned)")
    if (args.checkpoint is None) != (args.scene_from is None):
        raise ConfigError("checkpoint", "--checkpoint and --scene-from go together (offline)")
    if args.checkpoint is not None:
        explanation, note = explain_offline(
            args.checkpoint, args.scene_from, args.decision, args.seed
        )
        if note:
            print(note, file=sys.stderr)
    else:
        explanation = explain_online(args, args.decision, args.seed, args.timeout)
    if args.png is not None:
        from manigraph_lab.explain_viz import render_explanation

        render_explanation(explanation, args.png)
        print(f"wrote {args.png}", file=sys.stderr)
    if args.json:
        print(json.dumps(summary(explanation)), flush=True)
    else:
        print(explanation.sentence)
        for edge in explanation.edges:
            print(f"  edge {edge.src} -> {edge.dst}: {edge.weight:.3f}")
        for name, value in explanation.features.items():
            print(f"  feature {name}: {value:.3f}")
    return 0


def summary(explanation: Explanation) -> dict[str, object]:
    """The CLI's JSON: decision_id, object, goal, edges, features, sentence (and a bit more)."""
    data = explanation.to_builtins()
    keys = ("decision_id", "object", "goal", "edges", "features", "sentence")
    extra = ("episode_id", "scene_sequence", "policy", "fidelity", "seed")
    return {key: data[key] for key in (*keys, *extra)}


#: The planner's refusals that pass: asked again until the timeout.
RETRIED = (EXPLAINER_BUSY, EXPLAINER_WARMING_UP)


def explain_online(
    args: argparse.Namespace, decision: str | None, seed: int, timeout: float
) -> Explanation:
    """The planner's answer on ``manigraph/planner/explain`` within ``timeout`` seconds;
    BusError on error replies. A planner that explains every decision is often busy with the
    last one just when a person asks, and a planner just started may still be building its
    explainer: ``explainer_busy`` and ``explainer_warming_up`` are asked again, a little later
    each time, until ``timeout`` has passed (then that refusal is the error)."""
    from manigraph_shared.bus import Bus
    from manigraph_shared.errors import RequestRefused

    request = ExplainRequest(decision_id=decision, seed=seed)
    deadline = time.monotonic() + timeout
    pause = 0.1
    with Bus.open(bus_config_from_args(args, wait_seconds=timeout)) as bus:
        while True:
            left = deadline - time.monotonic()
            try:
                return bus.request(request, Explanation, timeout=max(left, 0.1))
            except RequestRefused as exc:
                again = any(code in str(exc) for code in RETRIED)
                if not again or time.monotonic() + pause >= deadline:
                    raise
            time.sleep(pause)
            pause = min(pause * 2, 0.5)


def explain_offline(
    checkpoint: Path, log: Path, decision: str | None, seed: int
) -> tuple[Explanation, str]:
    """Explain what ``checkpoint`` decides on the scene of a decision recorded in ``log``
    (``decision``, or the last one; without recorded decisions, the log's last scene).

    Returns the explanation and a note, non-empty when the log recorded another choice (e.g.
    the expert's) than the checkpoint makes: the checkpoint's own choice is the one explained.
    """
    from manigraph_planner.explain import SceneExplainer
    from manigraph_planner.policies.gnn import GNNPolicy
    from manigraph_shared.mcap_log import read_log

    if not log.is_file():
        raise LogError(f"scene-from: no such file: {log}")
    scenes: dict[tuple[str, int], Scene] = {}
    actions: list[Action] = []
    last_scene: Scene | None = None
    for item in read_log(log, [Scene.key, Action.key]):
        message = item.decode()
        if isinstance(message, Scene):
            scenes[(message.episode_id, message.sequence)] = last_scene = message
        elif isinstance(message, Action):
            actions.append(message)
    explainer = SceneExplainer(GNNPolicy.from_checkpoint(checkpoint))
    if decision is not None:
        actions = [a for a in actions if a.decision_id == decision]
        if not actions:
            raise LogError(f"decision: '{decision}' is not a decision recorded in {log}")
    if not actions:
        if last_scene is None:
            raise LogError(f"scene-from: {log} holds no scene")
        return explainer.explain_scene(last_scene, seed), ""
    action = actions[-1]
    scene = scenes.get((action.episode_id, action.scene_sequence))
    if scene is None:
        raise LogError(f"decision: the scene of '{action.decision_id}' is not in {log}")
    own = explainer.explain_scene(scene, seed).replace(decision_id=action.decision_id)
    note = ""
    if (own.object, own.goal) != (action.object_id, action.goal_id):
        note = (
            f"note: the log recorded {action.object_id} -> {action.goal_id} "
            f"({action.policy}); {own.policy} chooses {own.object} -> {own.goal} on that "
            "scene, which is what is explained"
        )
    return own, note


explain_command = Command(
    help="why did the planner choose that? explain its latest (or one) decision over Zenoh",
    configure=_configure,
    run=_run,
)


def _study_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-o",
        "--out",
        type=Path,
        default=Path("results/explain-study"),
        help="folder of the table (default: results/explain-study)",
    )
    parser.add_argument(
        "--archs",
        nargs="+",
        default=["gat", "gated", "gcn", "sage"],
        help="architectures to train and explain (default: gat gated gcn sage)",
    )
    parser.add_argument(
        "--trajectories", type=int, nargs="+", default=[5, 100], help="training set sizes"
    )
    parser.add_argument("--decisions", type=int, default=100, help="decisions explained per cell")
    parser.add_argument("--epochs", type=int, default=150, help="training epochs (default: 150)")
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of training and explaining (default: 0)"
    )
    parser.add_argument(
        "--demo-tasks",
        nargs="+",
        default=["box-pack", "box-unpack"],
        help="tasks the training demonstrations are drawn from (default: box-pack box-unpack)",
    )


def _study_run(args: argparse.Namespace) -> int:
    import torch

    from manigraph_lab.explain_study import StudySpec, run_study

    torch.set_num_threads(2)
    spec = StudySpec(
        archs=tuple(args.archs),
        trajectories=tuple(args.trajectories),
        decisions=args.decisions,
        epochs=args.epochs,
        seed=args.seed,
        demo_tasks=tuple(args.demo_tasks),
    )
    table = run_study(spec, args.out, progress=sys.stderr)  # bars on a terminal only
    print(table)
    return 0


study_command = Command(
    help="reproduce the paper's Table 'gnn': top-2 features per architecture and data size",
    configure=_study_configure,
    run=_study_run,
)


def _faithfulness_configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--checkpoints",
        type=Path,
        nargs="+",
        default=[Path(f"checkpoints/{arch}.pt") for arch in ("gcn", "sage", "gated", "gat")],
        help="policies whose decisions are explained (name: the file's stem)",
    )
    parser.add_argument("--decisions", type=int, default=100, help="decisions per task and policy")
    parser.add_argument(
        "--objectives",
        nargs="+",
        default=["distribution", "pair-context"],
        help="explainer objectives to compare (distribution, pair, pair-context)",
    )
    parser.add_argument("-o", "--out", type=Path, help="also write the table to this file")


def _faithfulness_run(args: argparse.Namespace) -> int:
    from manigraph_lab.explain_faithfulness import run, table
    from manigraph_planner.explain.config import ExplainerConfig

    for objective in args.objectives:
        ExplainerConfig(objective=objective)  # a bad name stops here, naming the field
    cells = run({p.stem: p for p in args.checkpoints}, args.decisions, tuple(args.objectives))
    text = table(cells)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")
    print(text)
    return 0


faithfulness_command = Command(
    help="how faithful are the explanations: PyG fidelity+/- and top-edge rate per objective",
    configure=_faithfulness_configure,
    run=_faithfulness_run,
)
