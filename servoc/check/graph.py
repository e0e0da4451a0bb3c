"""Cycles in a directed graph of names (which sequence plays which), without recursion."""

from __future__ import annotations

from collections import deque

Graph = dict[str, list[str]]        # node -> its successors, in order; every node is a key


def strongly_connected(graph: Graph) -> list[list[str]]:
    """The strongly connected components, by Tarjan's algorithm run on an explicit stack."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    sccs: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, 0)]
        while work:
            v, i = work.pop()
            if i == 0:
                index[v] = low[v] = len(index)
                stack.append(v)
                on_stack.add(v)
            succ = graph.get(v, [])
            recurse = False
            while i < len(succ):
                w = succ[i]
                i += 1
                if w not in index:
                    work.append((v, i))
                    work.append((w, 0))
                    recurse = True
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            if recurse:
                continue
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                sccs.append(comp)
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[v])
    return sccs


def cycles(graph: Graph) -> list[list[str]]:
    """One shortest cycle through each strongly connected component that has one, as the path
    start -> ... (back to start), from the component's first node in the graph's order;
    the cycles in the order of their starts."""
    order = {n: i for i, n in enumerate(graph)}
    found = []
    for comp in sorted(strongly_connected(graph), key=lambda c: min(order[n] for n in c)):
        start = min(comp, key=order.__getitem__)
        if len(comp) == 1 and start not in graph[start]:
            continue
        found.append(shortest_cycle(graph, start, set(comp)))
    return found


def shortest_cycle(graph: Graph, start: str, members: set[str]) -> list[str]:
    """The shortest path start -> ... -> start within `members` (start only, for a self-loop)."""
    if start in graph[start]:
        return [start]
    prev: dict[str, str] = {}
    queue = deque([start])
    seen = {start}
    while queue:
        v = queue.popleft()
        for w in graph.get(v, []):
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(prev[path[-1]])
                return list(reversed(path))
            if w in members and w not in seen:
                seen.add(w)
                prev[w] = v
                queue.append(w)
    return [start]
