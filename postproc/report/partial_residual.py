"""The partial-residual plot of diagnose's verdict: the residual against the variable (or
pair) it follows, with the smooth function of them that the held-out share measures.

The residual is shown along the direction the smooth function moves the measured point
most (its principal direction), so one panel carries what three per-axis panels would
spread thin.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .figures import RESIDUAL  # noqa: E402

LEVEL_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd")


def _principal(fitted: np.ndarray) -> np.ndarray:
    """The unit direction (3,) along which the smooth function varies most."""
    _, _, vt = np.linalg.svd(fitted - fitted.mean(axis=0), full_matrices=False)
    return vt[0]


def _axis_label(variables: dict, name: str) -> str:
    label, unit, _, _ = variables[name]
    return f"{label} ({unit})" if unit else label


def partial_residual(variables: dict, structure, residual: np.ndarray, fitted: np.ndarray):
    """Figure: ``residual`` (N, 3) and the smooth ``fitted`` (N, 3) of the ``structure``'s
    variables, along its principal direction, against them."""
    direction = _principal(fitted)
    r, f = residual @ direction, fitted @ direction
    names = structure.variables
    what = f"residual along ({direction[0]:+.2f}, {direction[1]:+.2f}, {direction[2]:+.2f}) (mm)"
    title = f"Residual against {structure.name}: a smooth function explains {100 * structure.explained:.0f}% of the held-out variance"
    if len(names) == 1:
        fig, ax = plt.subplots(figsize=(9, 5), constrained_layout=True)
        x = variables[names[0]][2]
        order = np.argsort(x)
        ax.scatter(x, r, s=8, alpha=0.4, color="#7f7f7f", label="residual at each pose")
        ax.plot(x[order], f[order], color=RESIDUAL, lw=2.5, label="smooth function of it")
        ax.set_xlabel(_axis_label(variables, names[0]))
        ax.set_ylabel(what)
        ax.legend(fontsize=9)
        ax.grid(alpha=0.3)
        ax.set_title(title, fontsize=11)
        return fig
    a, b = names
    if variables[a][3] and not variables[b][3]:
        a, b = b, a  # the continuous one on the horizontal axis
    xa, xb = variables[a][2], variables[b][2]
    fig, axes = plt.subplots(1, 2, figsize=(13, 5), constrained_layout=True)
    if variables[b][3]:  # continuous x categorical: one series per level
        for k, level in enumerate(np.unique(xb)):
            pick = xb == level
            order = np.argsort(xa[pick])
            colour = LEVEL_COLOURS[k % len(LEVEL_COLOURS)]
            axes[0].scatter(xa[pick], r[pick], s=8, alpha=0.4, color=colour, label=f"{b} = {level:g}: residual")
            axes[0].plot(xa[pick][order], f[pick][order], color=colour, lw=2.5, label=f"{b} = {level:g}: smooth function")
        axes[0].legend(fontsize=8)
    else:
        points = axes[0].scatter(xa, r, c=xb, s=10, cmap="viridis")
        fig.colorbar(points, ax=axes[0], label=_axis_label(variables, b))
    axes[0].set_xlabel(_axis_label(variables, a))
    axes[0].set_ylabel(what)
    axes[0].set_title("residual at each pose", fontsize=10)
    axes[0].grid(alpha=0.3)
    surface = axes[1].scatter(xa, xb + (np.random.default_rng(0).uniform(-0.2, 0.2, len(xb)) if variables[b][3] else 0.0), c=f, s=14, cmap="coolwarm")
    fig.colorbar(surface, ax=axes[1], label="smooth function along the same direction (mm)")
    axes[1].set_xlabel(_axis_label(variables, a))
    axes[1].set_ylabel(_axis_label(variables, b))
    axes[1].set_title("the smooth function of both, at each pose", fontsize=10)
    axes[1].grid(alpha=0.3)
    fig.suptitle(title, fontsize=12)
    return fig
