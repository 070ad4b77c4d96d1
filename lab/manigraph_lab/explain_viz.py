"""The paper's Figure "explainer_viz" for one ``Explanation``: nodes where they are, the chosen
object and goal circled, the kept edges drawn with width by weight, the top features listed."""

from __future__ import annotations

from pathlib import Path

from manigraph_shared.errors import ConfigError
from manigraph_shared.messages import Explanation

__all__ = ["render_explanation"]

_COLOURS = {"block": "tab:blue", "cover": "tab:brown", "block-goal": "tab:green"}
_VIEWS = {"xz": ("x", "z"), "xy": ("x", "y"), "yz": ("y", "z")}


def render_explanation(
    explanation: Explanation, path: Path, views: tuple[str, ...] = ("xz", "xy")
) -> Path:
    """Write the picture of ``explanation`` as PNG to ``path``; one panel per view.

    Args:
        explanation: must carry ``nodes`` (the planner always fills them).
        path: the PNG file to write (parent directories are created).
        views: axis pairs to draw, each ``xz`` (side), ``xy`` (top) or ``yz``.

    Raises:
        ConfigError: an unknown view, or an explanation without nodes.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for view in views:
        if view not in _VIEWS:
            raise ConfigError("views", f"'{view}' is not one of {', '.join(_VIEWS)}")
    if not explanation.nodes:
        raise ConfigError("nodes", "the explanation carries no node positions to draw")
    where = {n.id: n for n in explanation.nodes}
    fig, axes = plt.subplots(1, len(views), figsize=(5.5 * len(views), 5.0), squeeze=False)
    widest = max((e.weight for e in explanation.edges), default=1.0) or 1.0
    for ax, view in zip(axes[0], views, strict=True):
        a, b = _VIEWS[view]

        def at(node_id: str, a: str = a, b: str = b) -> tuple[float, float]:
            p = where[node_id].position
            return getattr(p, a), getattr(p, b)

        for rank, edge in enumerate(explanation.edges):
            (x0, y0), (x1, y1) = at(edge.src), at(edge.dst)
            ax.annotate(
                "",
                xy=(x1, y1),
                xytext=(x0, y0),
                arrowprops={
                    "arrowstyle": "-|>",
                    "lw": 1.0 + 5.0 * edge.weight / widest,
                    "color": "tab:red" if rank == 0 else "tab:orange",
                    "alpha": 0.9,
                    "connectionstyle": "arc3,rad=0.25",  # visible between stacked nodes
                },
            )
        for node in explanation.nodes:
            x, y = at(node.id)
            goal = node.category.endswith("goal")
            ax.scatter(
                x,
                y,
                s=260 if goal else 120,
                marker="s" if not goal else "o",
                facecolors=_COLOURS.get(node.category, "tab:gray") if not goal else "none",
                edgecolors=_COLOURS.get(node.category, "tab:gray"),
                linewidths=1.5,
                zorder=3,
            )
            offset = (6, -10) if goal else (6, 4)  # a filled goal and its block coincide
            ax.annotate(node.id, (x, y), textcoords="offset points", xytext=offset, fontsize=7)
        for chosen in (explanation.object, explanation.goal):
            x, y = at(chosen)
            ax.scatter(x, y, s=700, facecolors="none", edgecolors="black", linewidths=2.5, zorder=4)
        ax.set_xlabel(f"{a} [m]")
        ax.set_ylabel(f"{b} [m]")
        ax.set_title(f"{view} view")
        ax.margins(0.15)
        ax.set_aspect("equal", adjustable="datalim")
    top = ", ".join(f"{name} {value:.2f}" for name, value in list(explanation.features.items())[:3])
    fig.suptitle(
        f"{explanation.decision_id or 'scene'}: {explanation.object} -> {explanation.goal}"
        f"   (features: {top})",
        fontsize=10,
    )
    fig.text(0.5, 0.01, explanation.sentence, ha="center", fontsize=8, wrap=True)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path
