"""Figures of the placement search (seed 002). Each function returns a matplotlib Figure."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import BoundaryNorm, ListedColormap  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from postproc.process.placement_branch import REASONS, reason_counts  # noqa: E402

BEST, CURRENT = "#1f77b4", "#ff7f0e"
# One colour per infeasibility reason (placement_branch.REASONS order; index 0, feasible, unused)
REASON_COLOURS = ("#ffffff", "#d9d9d9", "#e377c2", "#fdd0a2", "#fdae6b", "#fd8d3c", "#e6550d", "#a63603", "#7f2704",
                  "#8c564b", "#9e9ac8", "#6a51a3", "#3f007d", "#252525")


def error_maps(result, current_xyt=None, max_panels: int = 24):
    """Mean normal error over (x, y), one panel per theta (up to max_panels, evenly
    picked); infeasible cells coloured by their reason (``result.grid_reason``); the best
    candidate (star) and the current placement (circle) marked on their theta's panel."""

    thetas = result.thetas
    pick = np.unique(np.linspace(0, len(thetas) - 1, min(len(thetas), max_panels)).round().astype(int))
    cols = min(4, len(pick))
    rows = int(np.ceil(len(pick) / cols))
    xs, ys = result.xs, result.ys
    span_x = max(float(np.ptp(xs)), 1.0)
    span_y = max(float(np.ptp(ys)), 1.0)
    panel_h = float(np.clip(3.6 * span_y / span_x, 1.6, 4.2)) + 0.9  # equal aspect plus labels
    legend_rows = int(np.ceil((len(reason_counts(result.grid_reason)) + 2) / 4))
    legend_h = 0.3 + 0.28 * legend_rows  # inches under the axis labels: the legend and its title
    height = panel_h * rows + 1.3 + legend_h
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols + 1.2, height), squeeze=False)
    # fixed margins (constrained layout costs seconds per figure on a busy machine)
    fig.subplots_adjust(left=0.07, right=0.86, top=1 - 0.55 / height, bottom=(0.95 + legend_h) / height, wspace=0.45, hspace=0.9 / panel_h)
    grid_um = result.grid_mean_mm * 1000.0
    finite = grid_um[np.isfinite(grid_um)]
    vmin, vmax = (finite.min(), finite.max()) if finite.size else (0.0, 1.0)
    cmap = plt.get_cmap("viridis").with_extremes(bad="#d9d9d9")
    extent = _edges(xs), _edges(ys)
    image = None
    reason_cmap = ListedColormap(REASON_COLOURS)
    reason_norm = BoundaryNorm(np.arange(len(REASON_COLOURS) + 1) - 0.5, len(REASON_COLOURS))
    for ax, k in zip(axes.flat, pick):
        values = np.ma.masked_invalid(grid_um[:, :, k].T)
        image = ax.pcolormesh(extent[0], extent[1], values, cmap=cmap, vmin=vmin, vmax=vmax, shading="flat")
        why = np.ma.masked_equal(result.grid_reason[:, :, k].T.astype(int), 0)
        if why.count():
            ax.pcolormesh(extent[0], extent[1], why, cmap=reason_cmap, norm=reason_norm, shading="flat", edgecolors="face")
        if np.isclose(result.grid_best[2], thetas[k]):
            ax.plot(result.grid_best[0], result.grid_best[1], "*", color="red", markersize=14, markeredgecolor="white")
        if current_xyt is not None and np.isclose(current_xyt[2], thetas[k]):
            ax.plot(current_xyt[0], current_xyt[1], "o", color="white", markersize=9, markeredgecolor="black", markeredgewidth=1.5)
        ax.set_title(f"θ = {thetas[k]:g}°", fontsize=10)
        ax.set_xlabel("workpiece x (mm, base frame)")
        ax.set_ylabel("workpiece y (mm)")
        ax.set_aspect("equal")
    for ax in list(axes.flat)[len(pick):]:
        ax.set_visible(False)
    if image is not None:
        fig.colorbar(image, cax=fig.add_axes([0.89, 0.15, 0.015, 0.7]), label="mean normal error (µm)")
    counts = reason_counts(result.grid_reason)
    handles = [Patch(facecolor=REASON_COLOURS[REASONS.index(name)], edgecolor="#7f7f7f", label=f"{name} ({n})") for name, n in counts.items()]
    handles.append(Line2D([], [], marker="*", color="red", markeredgecolor="white", markersize=14, linestyle="none", label="best grid candidate"))
    if current_xyt is not None:
        handles.append(Line2D([], [], marker="o", color="white", markeredgecolor="black", markeredgewidth=1.5, markersize=9, linestyle="none", label="current placement"))
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 4), fontsize=9, frameon=False,
               title="infeasible cells by reason (count over the whole grid)", title_fontsize=9)
    shown = "" if len(pick) == len(thetas) else f" ({len(pick)} of {len(thetas)} θ values shown)"
    fig.suptitle(f"Force-induced mean normal error over workpiece placements{shown}", fontsize=12)
    return fig


def _edges(centres: np.ndarray) -> np.ndarray:
    if len(centres) == 1:
        return np.array([centres[0] - 0.5, centres[0] + 0.5])
    mid = (centres[1:] + centres[:-1]) / 2.0
    return np.concatenate([[2 * centres[0] - mid[0]], mid, [2 * centres[-1] - mid[-1]]])


def path_errors(distance_mm, best_mm, current_mm=None, best_label="best placement", current_label="current placement"):
    """Normal error along the path (µm against path length) at the best and the current placement."""
    fig, ax = plt.subplots(figsize=(8, 4))
    fig.subplots_adjust(left=0.1, right=0.97, top=0.9, bottom=0.13)
    ax.plot(distance_mm, np.asarray(best_mm) * 1000.0, "-o", color=BEST, markersize=3, label=best_label)
    if current_mm is not None:
        ax.plot(distance_mm, np.asarray(current_mm) * 1000.0, "-s", color=CURRENT, markersize=3, label=current_label)
    ax.set_xlabel("path length along the cut (mm)")
    ax.set_ylabel("normal error n·ΔX (µm)")
    ax.set_title("Force-induced normal error along the path")
    ax.grid(alpha=0.3)
    ax.legend()
    return fig
