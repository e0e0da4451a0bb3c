"""The house's floors: servoc's modules import only modules below them, never one that comes
after them in the pipeline (every import counted, those inside functions too)."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "servoc"


def component(path: Path) -> str:
    """servoc/plan.py -> plan; servoc/lint/rules/x.py -> lint (a package is one component)."""
    parts = path.relative_to(PACKAGE).with_suffix("").parts
    return parts[0]


def imports() -> dict[str, set[str]]:
    """component -> the servoc components it imports."""
    graph: dict[str, set[str]] = {}
    for path in PACKAGE.rglob("*.py"):
        me = component(path)
        package = ["servoc", *path.relative_to(PACKAGE).parts[:-1]]
        out = graph.setdefault(me, set())
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = package[:len(package) - node.level + 1] if node.level else []
                full = base + (node.module.split(".") if node.module else [])
                if full[:1] != ["servoc"]:
                    continue
                targets = [full[1]] if len(full) > 1 else [a.name for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name.split(".")[1] for a in node.names if a.name.startswith("servoc.")]
            else:
                continue
            out.update(t for t in targets if t != me)
    return graph


def test_the_import_graph_has_no_cycle():
    graph = imports()
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            assert state.get(nxt) != 1, "import cycle: " + " -> ".join(path[path.index(nxt):] + [nxt])
            if nxt not in state:
                visit(nxt)
        path.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)


def test_the_planner_knows_nothing_of_code():
    graph = imports()
    below_code = {"plan", "steps", "flow", "imports"}
    code = {"codegen", "layout", "wcet", "toolchain", "sim", "verify", "api", "cli", "lsp"}
    for low in below_code:
        assert not graph[low] & code, (low, graph[low] & code)
    assert "plan" not in graph["codegen"] and "plan" not in graph["flow"] and graph["steps"] <= {"model", "walk", "source", "units"}
