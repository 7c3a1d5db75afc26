"""Draw docs/img/architecture.png: the package's folders on their floors, with the imports between them.

Run: .venv/bin/python scripts/draw_architecture.py [--output PATH]

The graph is the one tests/test_import_graph.py checks (every import of a postproc module,
at module level or inside a function, read with ``ast``); each box is a folder of postproc
(or the ground: the top-level modules every folder may use), each arrow the imports from one
folder into another, as thick as their number. Prints the counts the caption in
docs/ARCHITECTURE.md quotes.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import FancyArrowPatch, FancyBboxPatch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# The graph and the floors are the import test's own, so the picture shows what the test checks.
sys.path.insert(0, str(ROOT / "tests"))
from test_import_graph import FLOORS, GROUND, circles, import_graph  # noqa: E402

GROUND_ROOM = "ground"
TOP_ROOM = "top"  # postproc/__init__.py and __main__.py: the entry points
PLUGINS_ROOM = "plugins"  # postproc/plugins.py: users' effects, predictors, languages; above model/ and programs/


def room(module: str) -> str:
    """The folder a module lies in, or the ground / top room for the package's own files."""
    parts = module.split(".")
    if len(parts) > 1 and parts[1] in FLOORS:
        return parts[1]
    if len(parts) > 1 and parts[1] in GROUND:
        return GROUND_ROOM
    return PLUGINS_ROOM if module == "postproc.plugins" else TOP_ROOM


def folder_arrows(graph: dict[str, dict[str, str]]) -> Counter:
    """{(from room, to room): number of module imports} between different rooms."""
    arrows = Counter()
    for module, targets in graph.items():
        # `import postproc` (the version) is no arrow: importing any module of it runs __init__ anyway.
        for target in (t for t in targets if t != "postproc"):
            a, b = room(module), room(target)
            if a != b:
                arrows[(a, b)] += 1
    return arrows


def floor_of(name: str) -> int:
    return {GROUND_ROOM: 0, PLUGINS_ROOM: 3, TOP_ROOM: max(FLOORS.values()) + 1}.get(name, FLOORS.get(name, 0))


def positions() -> dict[str, tuple[float, float]]:
    """Box centres: one row per floor, the floor's folders side by side."""
    rows: dict[int, list[str]] = {}
    for name in [*FLOORS, GROUND_ROOM, PLUGINS_ROOM, TOP_ROOM]:
        rows.setdefault(floor_of(name), []).append(name)
    out = {}
    for level, names in rows.items():
        for k, name in enumerate(sorted(names)):
            out[name] = ((k + 1) / (len(names) + 1), float(level))
    return out


def draw(arrows: Counter, modules_per_room: Counter, output: Path) -> None:
    where = positions()
    fig, ax = plt.subplots(figsize=(11, 8.5))
    top = max(y for _, y in where.values())
    for level in range(int(top) + 1):
        ax.axhspan(level - 0.42, level + 0.42, color="0.95" if level % 2 else "0.90", zorder=0)
        ax.text(-0.02, level, f"floor {level}", ha="right", va="center", fontsize=9, color="0.35")
    widest = max(arrows.values())
    for (a, b), count in sorted(arrows.items(), key=lambda kv: kv[1]):
        (xa, ya), (xb, yb) = where[a], where[b]
        up = yb >= ya  # an arrow up a floor would break the layout's rule: drawn red
        ax.add_patch(FancyArrowPatch((xa, ya - 0.2), (xb, yb + 0.2), arrowstyle="-|>", mutation_scale=10,
                                     lw=0.6 + 3.0 * count / widest, color="tab:red" if up else "0.45", alpha=0.55,
                                     connectionstyle="arc3,rad=0.08", zorder=1))
    for name, (x, y) in where.items():
        label = f"{name}/" if name in FLOORS else {GROUND_ROOM: ", ".join(sorted(GROUND)), PLUGINS_ROOM: "plugins.py",
                                                    TOP_ROOM: "__init__, __main__"}[name]
        half = max(0.075, 0.0045 * max(len(line) for line in label.splitlines()))  # wide enough for its label
        ax.add_patch(FancyBboxPatch((x - half, y - 0.2), 2 * half, 0.4, boxstyle="round,pad=0.01", fc="white", ec="tab:blue", lw=1.2, zorder=2))
        ax.text(x, y + 0.04, label, ha="center", va="center", fontsize=9 if name in FLOORS else 7, zorder=3)
        ax.text(x, y - 0.13, f"{modules_per_room[name]} module" + "s" * (modules_per_room[name] != 1), ha="center", va="center", fontsize=7, color="0.4", zorder=3)
    ax.set_xlim(-0.1, 1.02)
    ax.set_ylim(-0.6, top + 0.6)
    ax.axis("off")
    ax.set_title("postproc drawn from its imports: each box a folder, each arrow the imports from one folder into another\n"
                 "(thicker: more modules imported; every arrow runs down the floors)", fontsize=10)
    fig.tight_layout()
    fig.savefig(output, dpi=130)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=ROOT / "docs" / "img" / "architecture.png")
    opts = parser.parse_args()
    graph = import_graph()
    arrows = folder_arrows(graph)
    modules_per_room = Counter(room(m) for m in graph)
    up = [(a, b) for a, b in arrows if floor_of(b) >= floor_of(a)]
    draw(arrows, modules_per_room, opts.output)
    print(f"{len(graph)} modules in {len(modules_per_room)} boxes on {len({floor_of(r) for r in modules_per_room})} floors; "
          f"{sum(len(t) for t in graph.values())} module imports, {len(arrows)} folder arrows ({sum(arrows.values())} imports), "
          f"{len(up)} up a floor, {len(circles(graph))} circles -> {opts.output}")


if __name__ == "__main__":
    main()
