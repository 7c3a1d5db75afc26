"""Figures of the explain loop. Each function returns a matplotlib Figure; nothing is shown.

Colours are fixed across figures: x, y, z residual components; measured, model, residual
error vectors; before/after.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from postproc.model.candidates import MIN_PROGRESS, MIN_STABILITY  # noqa: E402

AXIS_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")  # x red, y green, z blue
MEASURED, MODEL, RESIDUAL = "#7f7f7f", "#1f77b4", "#d62728"
BEFORE, AFTER = "#ff7f0e", "#1f77b4"


#: arrow widths (share of the panel) of the layers drawn on top of each other: the one
#: below wider, so at hundreds of poses both stay visible
LAYER_WIDTHS = (0.0055, 0.0025)


def _quiver_views(axes, nominal_mm, layers, gain, title_suffix):
    radius = np.hypot(nominal_mm[:, 0], nominal_mm[:, 1])
    views = (
        ("top view", nominal_mm[:, 0], nominal_mm[:, 1], "x (mm)", "y (mm)"),
        ("side view", radius, nominal_mm[:, 2], "radius from axis 1 (mm)", "z (mm)"),
    )
    for v, (ax, (title, px, py, xl, yl)) in enumerate(zip(axes, views)):
        xs, ys = [px], [py]
        for layer, (err, colour, label) in enumerate(layers):
            if v == 0:
                ux, uy = err[:, 0], err[:, 1]
            else:  # radial component against height
                ux = (err[:, 0] * nominal_mm[:, 0] + err[:, 1] * nominal_mm[:, 1]) / np.maximum(radius, 1e-9)
                uy = err[:, 2]
            ax.quiver(px, py, ux * gain, uy * gain, angles="xy", scale_units="xy", scale=1, color=colour, width=LAYER_WIDTHS[layer] if len(layers) > 1 else 0.003, alpha=0.55 if layer == 0 and len(layers) > 1 else 0.9, label=label)
            xs.append(px + ux * gain)
            ys.append(py + uy * gain)
        ax.set_title(f"{title}: {title_suffix}", fontsize=10)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        _limits_around(ax, np.concatenate(xs), np.concatenate(ys))
        ax.grid(alpha=0.3)
    axes[0].figure.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center" if len(layers) > 1 else "outside lower right", ncol=len(layers), fontsize=9)


PANEL_RATIO = 0.8


def _limits_around(ax, x, y, margin: float = 0.05):
    """Equal-scale limits that hold every arrow's base and tip (quiver does not widen the
    view for its arrows, so without this the arrows at the edge are cut off)."""
    half_x, half_y = np.ptp(x) * (0.5 + margin), np.ptp(y) * (0.5 + margin)
    # Widen the shorter side to the panel's own shape (height/width about 0.8 in the 2 x 2
    # grid) so an equal-scale view fills its panel instead of leaving a thin strip.
    half_x, half_y = max(half_x, half_y / PANEL_RATIO, 0.5), max(half_y, half_x * PANEL_RATIO, 0.5)
    cx, cy = (x.min() + x.max()) / 2, (y.min() + y.max()) / 2
    ax.set_xlim(cx - half_x, cx + half_x)
    ax.set_ylim(cy - half_y, cy + half_y)
    ax.set_aspect("equal", adjustable="box")


def _gain(nominal_mm, err):
    """Arrow gain so a long arrow (90th percentile) spans about the spacing between poses
    (at most 8 % of the workspace): at hundreds of poses the arrows do not hide each other."""
    span = max(np.ptp(nominal_mm, axis=0).max(), 1.0)
    spacing = span / np.sqrt(max(len(nominal_mm), 1))
    return min(0.08 * span, 1.2 * spacing) / max(np.percentile(np.linalg.norm(err, axis=1), 90), 1e-9)


def error_vectors(nominal_mm: np.ndarray, measured_err: np.ndarray, model_err: np.ndarray, residual: np.ndarray):
    """Top row: measured error against the model's prediction. Bottom row: what is left, at its own scale."""
    fig, axes = plt.subplots(2, 2, figsize=(13, 10.5), constrained_layout=True)
    gain = _gain(nominal_mm, measured_err)
    _quiver_views(axes[0], nominal_mm, ((measured_err, MEASURED, "measured error"), (model_err, MODEL, "model's prediction")), gain, f"measured vs model, arrows x{gain:.0f}")
    rgain = _gain(nominal_mm, residual)
    _quiver_views(axes[1], nominal_mm, ((residual, RESIDUAL, "residual (measured - model)"),), rgain, f"residual, arrows x{rgain:.0f}")
    fig.suptitle("Position error over the workspace (side view: radial and vertical components)", fontsize=13)
    return fig


def residual_vs_variables(breakdowns, variables, residual: np.ndarray, max_panels: int = 15):
    """Residual components against each variable, with binned means; significant panels marked."""
    shown = list(breakdowns)[:max_panels]
    cols = 3
    rows = int(np.ceil(len(shown) / cols)) or 1
    fig, axes = plt.subplots(rows, cols, figsize=(13, 3.2 * rows), constrained_layout=True, squeeze=False)
    for ax in axes.flat[len(shown):]:
        ax.axis("off")
    for ax, b in zip(axes.flat, shown):
        label, unit, values, categorical = variables[b.variable]
        jitter = np.random.default_rng(0).uniform(-0.15, 0.15, len(values)) if categorical else 0.0
        for k in range(3):
            ax.scatter(values + jitter, residual[:, k], s=5, alpha=0.25, color=AXIS_COLOURS[k])
            means = [m[k] for m in b.mean_mm]
            ax.plot(b.centres, means, "o-", color=AXIS_COLOURS[k], lw=2, ms=5, label=f"{'xyz'[k]} (bin mean)")
        ax.axhline(0, color="black", lw=0.8)
        ax.set_xlabel(f"{label} ({unit})" if unit else label)
        ax.set_ylabel("residual (mm)")
        mark = "significant" if b.significant else "not significant"
        ax.set_title(f"{b.variable}: {mark}, p = {b.p_adjusted:.1e}", fontsize=10, color="#b00000" if b.significant else "black")
        if categorical:
            ax.set_xticks([-1, 1])
            ax.set_xticklabels(["-1", "+1"])
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=8, loc="best")
    fig.suptitle("Residual (measured - model) against each variable, binned means; p Holm-corrected", fontsize=13)
    return fig


def histograms(before_mm: np.ndarray, after_mm: np.ndarray, before_label: str = "nominal robot", after_label: str = "model"):
    """3-D position error before and after the model."""
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    hi = max(before_mm.max(), after_mm.max())
    bins = np.linspace(0, hi * 1.02, 40)
    ax.hist(before_mm, bins=bins, alpha=0.6, color=BEFORE, label=f"{before_label}: RMS {np.sqrt(np.mean(before_mm**2)):.3f} mm")
    ax.hist(after_mm, bins=bins, alpha=0.7, color=AFTER, label=f"{after_label}: RMS {np.sqrt(np.mean(after_mm**2)):.3f} mm")
    ax.set_xlabel("3-D position error (mm)")
    ax.set_ylabel("poses")
    ax.set_title("Position error before and after the model")
    ax.legend()
    ax.grid(alpha=0.3)
    return fig


def candidates_chart(candidates, cv_rms_mm: float, floor_mm: float):
    """Cross-validated RMS with each candidate added, against the current model and the noise floor."""
    fig, ax = plt.subplots(figsize=(9, 0.6 * max(len(candidates), 2) + 1.8), constrained_layout=True)
    names = [c.effect for c in candidates][::-1]
    values = [c.rms_if_added_mm for c in candidates][::-1]
    colours = ["#2ca02c" if c.significant else "#bbbbbb" for c in candidates][::-1]
    ax.barh(names, values, color=colours)
    ax.axvline(cv_rms_mm, color="black", lw=1.5, label=f"current model: {cv_rms_mm:.4f} mm")
    ax.axvline(floor_mm, color="#9467bd", lw=1.5, ls="--", label=f"noise floor: {floor_mm:.4f} mm")
    for y, c in enumerate(candidates[::-1]):
        ax.text(c.rms_if_added_mm, y, f"  {100 * c.explained:.0f}% explained, {max(0.0, 100 * c.progress):.0f}% to the floor", va="center", fontsize=9)
    ax.set_xlabel("cross-validated RMS with the effect added (mm)")
    ax.set_title(f"Which missing effect?\ngreen: recommended (>= {100 * MIN_PROGRESS:.0f}% of the way to the noise floor "
                 f"in >= {100 * MIN_STABILITY:.0f}% of resamples)", fontsize=10)
    ax.set_xlim(0, max(values + [cv_rms_mm]) * 1.75)
    # The most explaining candidate sits at the top with the shortest bar: its right is free.
    ax.legend(loc="upper right", fontsize=9)
    ax.grid(axis="x", alpha=0.3)
    return fig


def ladder_chart(rows, floor_mm: float):
    """Error per step of the ladder: each step adds one effect."""
    fig, ax = plt.subplots(figsize=(9, 4.8), constrained_layout=True)
    x = np.arange(len(rows))
    ax.plot(x, [r["cv_rms_mm"] for r in rows], "o-", color=AFTER, lw=2, label="cross-validated RMS")
    if "val_rms_mm" in rows[0]:
        ax.plot(x, [r["val_rms_mm"] for r in rows], "s--", color=BEFORE, lw=2, label="validation-set RMS")
    ax.axhline(floor_mm, color="#9467bd", ls="--", label=f"noise floor {floor_mm:.3f} mm")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels([("+ " if i else "") + r["added"] for i, r in enumerate(rows)], rotation=25, ha="right", fontsize=9)
    ax.set_ylabel("3-D position error RMS (mm, log scale)")
    ax.set_title("Adding effects one by one: the error falls")
    for xi, r in zip(x, rows):
        ax.annotate(f"{r['cv_rms_mm']:.3f}", (xi, r["cv_rms_mm"]), textcoords="offset points", xytext=(0, 8), ha="center", fontsize=8)
    ax.legend()
    ax.grid(alpha=0.3, which="both")
    return fig
