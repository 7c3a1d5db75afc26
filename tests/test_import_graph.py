"""No import circles in postproc (issue 27).

The graph is drawn from the source text with ``ast``: every ``import`` and ``from ... import``
of a postproc module is an arrow, at module level or inside a function (an import inside a
function still ties the two modules together; it only hides the arrow). ``from pkg import
name`` points at ``pkg.name`` where that is a module, else at ``pkg``. A circle is named
with the file and line of each of its arrows.
"""

from __future__ import annotations

import ast
from collections import deque
from pathlib import Path

import postproc

PACKAGE = Path(postproc.__file__).parent


def _modules() -> dict[str, tuple[Path, bool]]:
    """{dotted name: (file, is a package's __init__)} of every module of postproc."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        out[".".join(parts[:-1] if is_package else parts)] = (path, is_package)
    return out


def _owner(name: str, modules) -> str | None:
    """The module ``name`` is, or lies in (a class or function imported from it)."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def _imported(node: ast.AST, package: str, modules) -> list[str]:
    """Dotted names one import statement reaches (``package``: where ``.`` points)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:
        base = package.split(".")[: len(package.split(".")) - node.level + 1]
        source = ".".join(base + ([node.module] if node.module else []))
    else:
        source = node.module or ""
    # `from pkg import sub` reaches the module pkg.sub where there is one, else pkg
    return [f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source for alias in node.names]


def import_graph() -> dict[str, dict[str, str]]:
    """{module: {module it imports: 'file:line' of the first such import}} within postproc."""
    modules = _modules()
    graph: dict[str, dict[str, str]] = {name: {} for name in modules}
    for name, (path, is_package) in modules.items():
        package = name if is_package else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            names = _imported(node, package, modules)
            for target in sorted({_owner(n, modules) for n in names if n.split(".")[0] == "postproc"} - {None, name}):
                graph[name].setdefault(target, f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
    return graph


def _components(graph: dict[str, dict[str, str]]) -> list[list[str]]:
    """Strongly connected components (Tarjan), iterative."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(graph[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(graph[child])))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                out.append(component)
    return out


def _circle(graph: dict[str, dict[str, str]], members: set[str]) -> list[str]:
    """One shortest circle through the first member, as 'a -> b (file:line)' steps."""
    start = min(members)
    came_from: dict[str, str] = {}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for child in sorted(graph[node]):
            if child == start:
                path = [node]
                while path[-1] != start:
                    path.append(came_from[path[-1]])
                path = path[::-1] + [start]
                return [f"{a} -> {b} ({graph[a][b]})" for a, b in zip(path, path[1:])]
            if child in members and child not in came_from and child != start:
                came_from[child] = node
                queue.append(child)
    return []


def circles(graph: dict[str, dict[str, str]]) -> list[list[str]]:
    return [_circle(graph, set(c)) for c in _components(graph) if len(c) > 1]


def test_the_graph_is_drawn():
    """The drawing sees the arrows it must (a broken drawing would find no circle anywhere)."""
    graph = import_graph()
    assert "postproc.programs.emit.writer" in graph["postproc.programs.dialects.krl.writer"]  # module level, relative
    assert "postproc.programs.dialects.rapid.parse" in graph["postproc.programs.dialects.rapid.writer"]  # from .parse import NAME
    assert "postproc.programs.dialects.krl.writer" in graph["postproc.programs.dialects.krl"]  # inside a method
    assert "postproc.cam.post" in graph["postproc"]


def test_a_circle_is_found_and_named():
    graph = {"a": {"b": "a.py:1"}, "b": {"c": "b.py:2"}, "c": {"a": "c.py:3", "d": "c.py:4"}, "d": {}}
    assert circles(graph) == [["a -> b (a.py:1)", "b -> c (b.py:2)", "c -> a (c.py:3)"]]


def test_no_import_circle():
    found = circles(import_graph())
    assert not found, "import circles:\n" + "\n\n".join("\n".join(c) for c in found)


# Floors below the languages: they ask a controller object they are given, never the registry.
BELOW_LANGUAGES = ("postproc.compensation", "postproc.programs.emit", "postproc.programs.parse", "postproc.robot.kinematics", "postproc.robot.posture",
                   "postproc.model.errormodel", "postproc.model.effects", "postproc.model.fast_model", "postproc.model.identify", "postproc.model.diagnose",
                   "postproc.model.sim", "postproc.model.learn", "postproc.robot.robots", "postproc.robot.dh", "postproc.programs.ir", "postproc.programs.arcs",
                   "postproc.compensation.segments", "postproc.robot.frames", "postproc.errors", "postproc.programs.controller", "postproc.programs.rotation_forms")


def _reached(graph: dict[str, dict[str, str]], start: str) -> dict[str, list[str]]:
    """{module: the path of imports from ``start`` to it} for every module ``start`` imports, however indirectly."""
    paths = {start: [start]}
    queue = deque([start])
    while queue:
        node = queue.popleft()
        for child in graph[node]:
            if child not in paths:
                paths[child] = paths[node] + [child]
                queue.append(child)
    return paths


def test_compensation_and_physics_import_no_language():
    graph = import_graph()
    bad = []
    for module in graph:
        if any(module == floor or module.startswith(floor + ".") for floor in BELOW_LANGUAGES):
            bad += [" -> ".join(path) for target, path in _reached(graph, module).items() if target.startswith("postproc.programs.dialects")]
    assert not bad, "below the languages, yet reaching one:\n" + "\n".join(sorted(bad)[:20])


# Modules above the physics but below the programs' floor that once reached a language
# (issue 27): model files through the plugin loader, engagement through place_program,
# placement through placement_branch. They are handed what they need, or import a module
# that knows no language (plugin_records, workpiece).
NO_LANGUAGE_EITHER = ("postproc.model.model_io", "postproc.model.plugin_records", "postproc.process.engagement", "postproc.programs.workpiece",
                      "postproc.process.placement", "postproc.process.placement_branch")


def test_model_files_engagement_and_placement_reach_no_language():
    graph = import_graph()
    bad = [" -> ".join(path) for module in NO_LANGUAGE_EITHER if module in graph
           for target, path in _reached(graph, module).items() if target.startswith("postproc.programs.dialects")]
    assert not bad, "reaching a language:\n" + "\n".join(sorted(bad)[:20])


def test_subdivide_is_handed_the_language():
    """subdivide takes the program's language as an argument (compensate / the CLI resolve it)."""
    graph = import_graph()
    assert not [t for t in graph["postproc.jobs.subdivide"] if t.startswith("postproc.programs.dialects")], graph["postproc.jobs.subdivide"]


# The folders of the flow layout, each on its floor (docs/ARCHITECTURE.md, "Who imports whom"):
# a folder imports only folders on lower floors. The ground (errors, files, progress, threads)
# is below all of them.
FLOORS = {"robot": 1, "fivex": 1, "model": 2, "programs": 2, "compensation": 3, "process": 3, "jobs": 4,
          "cam": 5, "suggest": 5, "report": 5, "cli": 6}
GROUND = {"errors", "files", "progress", "threads", "moved"}


def _folder(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in FLOORS else None


def test_folders_import_one_way():
    graph = import_graph()
    bad = []
    for module, targets in graph.items():
        here = _folder(module)
        parts = module.split(".")
        if len(parts) > 1 and parts[1] in GROUND:
            bad += [f"{module} -> {t} ({w}): the ground imports nothing of the house" for t, w in targets.items() if t.split(".")[1:2] and t.split(".")[1] not in GROUND]
        if here is None:
            continue
        for target, where in targets.items():
            there = _folder(target)
            if there is not None and there != here and FLOORS[there] >= FLOORS[here]:
                bad.append(f"{module} (floor {FLOORS[here]}) -> {target} (floor {FLOORS[there]}) at {where}")
    assert not bad, "imports that do not run down the floors:\n" + "\n".join(sorted(bad)[:30])


def test_every_folder_has_a_floor():
    folders = {p.name for p in PACKAGE.iterdir() if (p / "__init__.py").exists()}
    assert folders == set(FLOORS)
