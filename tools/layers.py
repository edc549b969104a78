"""The package import graph of `kartci`, from the code's own imports (`ast`, nothing is run).

    python tools/layers.py            # packages, their imports, and every cycle
    python tools/layers.py --late     # also list each import made inside a function
    python tools/layers.py --levels   # the packages by level, top to bottom (no cycle: arrows down)

A package is a subpackage of kartci (`kartci.runner`) or a top-level module (`kartci.atomic`);
`kartci` itself is the package's `__init__.py`. An import inside a function counts as an edge
too: it is a dependency all the same, only a late one. tests/test_layers.py asserts the result.
"""

from __future__ import annotations

import argparse
import ast
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1] / "kartci"


@dataclass(frozen=True)
class Edge:
    """One import of a kartci package by another."""

    source: str  # importing package
    target: str  # imported package
    where: str  # file:line of the import
    late: bool  # inside a function (or a class body) rather than at module level


def package_of(module: str) -> str:
    """`kartci.runner.jobs` -> `kartci.runner`; `kartci.atomic` -> `kartci.atomic`."""
    parts = module.split(".")
    if len(parts) == 1:
        return "kartci"
    head = ROOT.joinpath(*parts[1:2])
    return ".".join(parts[:2]) if head.is_dir() or head.with_suffix(".py").is_file() else "kartci"


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _targets(node: ast.Import | ast.ImportFrom, module: str, is_pkg: bool) -> list[str]:
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    base = module if is_pkg else module.rsplit(".", 1)[0]
    if node.level:
        for _ in range(node.level - 1):
            base = base.rsplit(".", 1)[0]
        name = f"{base}.{node.module}" if node.module else base
    else:
        name = node.module or ""
    # `from kartci import track`: a submodule is imported, not the package's __init__
    subs = [f"{name}.{a.name}" for a in node.names if _is_module(f"{name}.{a.name}")]
    return subs + ([name] if len(subs) < len(node.names) else [])


def _is_module(name: str) -> bool:
    if not name.startswith("kartci."):
        return False
    path = ROOT.joinpath(*name.split(".")[1:])
    return path.is_dir() or path.with_suffix(".py").is_file()


def edges(root: Path = ROOT) -> list[Edge]:
    """Every import of one kartci package by another (not within a package)."""
    out = []
    for path in sorted(root.rglob("*.py")):
        module = _module_name(path)
        source = package_of(module)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        late_nodes = {id(n) for f in ast.walk(tree)
                      if isinstance(f, ast.FunctionDef | ast.AsyncFunctionDef)
                      for n in ast.walk(f)}
        for node in ast.walk(tree):
            if not isinstance(node, ast.Import | ast.ImportFrom):
                continue
            if _type_checking_only(tree, node):
                continue
            for name in _targets(node, module, path.name == "__init__.py"):
                if name != "kartci" and not name.startswith("kartci."):  # another library
                    continue
                target = package_of(name)
                if target != source:
                    out.append(Edge(source, target, f"{path.relative_to(root.parent)}:"
                                    f"{node.lineno}", id(node) in late_nodes))
    return out


def _type_checking_only(tree: ast.Module, node: ast.AST) -> bool:
    """An import under `if TYPE_CHECKING:` is for the type checker only: no runtime edge."""
    for block in ast.walk(tree):
        if (isinstance(block, ast.If) and isinstance(block.test, ast.Name)
                and block.test.id == "TYPE_CHECKING"
                and any(n is node for b in block.body for n in ast.walk(b))):
            return True
    return False


def cycles(found: list[Edge]) -> list[list[str]]:
    """Strongly connected components of more than one package, largest first."""
    import numpy as np
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    names = sorted({e.source for e in found} | {e.target for e in found})
    at = {n: i for i, n in enumerate(names)}
    pairs = sorted({(at[e.source], at[e.target]) for e in found})
    rows, cols = (np.array(c, dtype=np.int64) for c in zip(*pairs, strict=True))
    graph = coo_matrix((np.ones(len(pairs)), (rows, cols)), shape=(len(names), len(names)))
    _, label = connected_components(graph, directed=True, connection="strong")
    comps = [[n for n, lab in zip(names, label, strict=True) if lab == k] for k in set(label)]
    return sorted((c for c in comps if len(c) > 1), key=len, reverse=True)


def levels(found: list[Edge]) -> dict[int, list[str]]:
    """Packages by level: 0 imports no other package, each level imports only lower ones (the
    longest import path down). Meaningful only without a cycle."""
    down: dict[str, set[str]] = defaultdict(set)
    for e in found:
        down[e.source].add(e.target)
    level: dict[str, int] = {}

    def of(name: str) -> int:
        if name not in level:
            level[name] = 0  # a guard against a cycle, which `cycles` reports
            level[name] = 1 + max((of(t) for t in down[name]), default=-1)
        return level[name]

    by: dict[int, list[str]] = defaultdict(list)
    for name in sorted({e.source for e in found} | {e.target for e in found}):
        by[of(name)].append(name)
    return dict(by)


def main() -> int:
    """Print the graph and its cycles; exit 1 when there is a cycle."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--late", action="store_true", help="list imports made inside functions")
    ap.add_argument("--levels", action="store_true", help="print the packages by level")
    args = ap.parse_args()
    found = edges()
    by: dict[tuple[str, str], list[Edge]] = defaultdict(list)
    for e in found:
        by[(e.source, e.target)].append(e)
    for (s, t), es in sorted(by.items()):
        late = sum(e.late for e in es)
        print(f"{s} -> {t}  ({len(es)} import(s){f', {late} late' if late else ''})")
    comps = cycles(found)
    print(f"\n{len(found)} imports between packages, {sum(e.late for e in found)} of them late")
    for comp in comps:
        print(f"cycle of {len(comp)} packages: {', '.join(comp)}")
    if args.levels:
        for k, names in sorted(levels(found).items(), reverse=True):
            print(f"level {k}: {'  '.join(n.removeprefix('kartci.') for n in names)}")
    if args.late:
        for e in found:
            if e.late:
                print(f"late: {e.where}: {e.source} -> {e.target}")
    return 1 if comps else 0


if __name__ == "__main__":
    raise SystemExit(main())
