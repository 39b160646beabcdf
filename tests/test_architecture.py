"""The layout stays honest: stages import the core and lower stages only, no import circles, no ``_private``
name imported across modules, no import hidden inside a function without a stated reason.

The rules are checked on the real ``components/`` tree and, to show the checker catches what it must, on small
synthetic packages written to a temporary folder.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: the stages of ``components/``, lowest first: a module may import its own stage and the stages before it
STAGES = ("core", "surfaces", "metrics", "planarize", "fields", "conical", "network", "subdivision", "fabrication",
          "harness")

#: a function-level import is allowed when its line (or the line before) says why, with this marker
DEFERRED_MARKER = "deferred import:"


def module_name(path: Path, root: Path) -> str:
    rel = path.relative_to(root).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _resolve(node: ast.ImportFrom, current: str, is_package: bool) -> str:
    if not node.level:
        return node.module or ""
    base = current.split(".") if is_package else current.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def scan(root: Path, top: str):
    """Every import between modules of package ``top`` under ``root``.

    Returns
    -------
    modules : set of str
    edges : list of (importer, imported, imported_names, lineno, in_function, line_text)
    """
    files = sorted((root / top).rglob("*.py"))
    modules = {module_name(p, root) for p in files}
    edges = []
    for p in files:
        src = p.read_text()
        lines = src.splitlines()
        tree = ast.parse(src)
        cur = module_name(p, root)
        is_pkg = p.name == "__init__.py"
        funcs = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
        inner = {id(n) for f in funcs for n in ast.walk(f) if n is not f}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                targets = [(a.name, []) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                mod = _resolve(node, cur, is_pkg)
                targets = []
                for a in node.names:
                    sub = f"{mod}.{a.name}"
                    targets.append((sub, []) if sub in modules else (mod, [a.name]))
            else:
                continue
            text = "\n".join(lines[max(0, node.lineno - 2): node.lineno])
            for mod, names in targets:
                if mod == top or mod.startswith(top + "."):
                    edges.append((cur, mod, names, node.lineno, id(node) in inner, text))
    return modules, edges


def stage_of(module: str, top: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def find_cycle(modules, edges):
    """One import circle among the module-level imports, as a list of modules, or ``None``."""
    graph = {m: set() for m in modules}
    for a, b, _, _, in_function, _ in edges:
        if b in graph and a != b:
            graph[a].add(b)
    state, stack = {}, []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state:
                found = visit(n)
                if found:
                    return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state:
            found = visit(m)
            if found:
                return found
    return None


def violations(root: Path, top: str, stages=STAGES) -> list[str]:
    """Every broken rule of the layout, one line each."""
    modules, edges = scan(root, top)
    out = []
    cycle = find_cycle(modules, edges)
    if cycle:
        out.append("import circle: " + " -> ".join(cycle))
    rank = {s: i for i, s in enumerate(stages)}
    for a, b, names, line, in_function, text in edges:
        sa, sb = stage_of(a, top), stage_of(b, top)
        if sa in rank and sb in rank and rank[sb] > rank[sa]:
            out.append(f"upward import: {a}:{line} imports {b} (stage {sb} is above {sa})")
        if sa is not None and (sa not in rank or (sb is not None and sb not in rank)):
            out.append(f"unknown stage: {a}:{line} ({sa} or {sb} is not in {stages})")
        private = [n for n in names if n.startswith("_")]
        if private and a != b:
            out.append(f"private import: {a}:{line} imports {', '.join(private)} from {b}")
        if in_function and DEFERRED_MARKER not in text:
            out.append(f"hidden import: {a}:{line} imports {b} inside a function without a '{DEFERRED_MARKER}' reason")
    return out


def test_components_layout_is_honest():
    assert violations(ROOT, "components") == []


def test_every_stage_is_a_package():
    present = {p.name for p in (ROOT / "components").iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert present == set(STAGES) - {"harness"}
    assert (ROOT / "components" / "harness.py").exists()


def test_ghserver_reaches_components_only_through_public_names():
    _, edges = scan(ROOT, "ghserver")
    files = sorted((ROOT / "ghserver").rglob("*.py"))
    bad = []
    for p in files:
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("components"):
                bad += [f"{p.name}:{node.lineno} {a.name}" for a in node.names if a.name.startswith("_")]
    assert bad == []
    assert find_cycle({e[0] for e in edges} | {e[1] for e in edges}, edges) is None


# ------------------------------------------------------------------------------------------------
# the checker itself, on synthetic packages


def _write(root: Path, files: dict[str, str]):
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)


CLEAN = {
    "pkg/__init__.py": "",
    "pkg/core/__init__.py": "",
    "pkg/core/base.py": "def unit(x):\n    return x\n",
    "pkg/fields/__init__.py": "",
    "pkg/fields/a.py": "from pkg.core.base import unit\n",
    "pkg/fields/b.py": "from pkg.fields import a\nfrom .a import unit\n",
}


def test_checker_passes_a_clean_package(tmp_path):
    _write(tmp_path, CLEAN)
    assert violations(tmp_path, "pkg", stages=("core", "fields")) == []


def test_checker_finds_an_import_circle(tmp_path):
    _write(tmp_path, {**CLEAN, "pkg/fields/a.py": "from pkg.fields import b\n"})
    found = violations(tmp_path, "pkg", stages=("core", "fields"))
    assert any(v.startswith("import circle:") and "pkg.fields.a" in v and "pkg.fields.b" in v for v in found)


def test_checker_finds_a_relative_import_circle(tmp_path):
    _write(tmp_path, {**CLEAN, "pkg/fields/a.py": "from . import b\n"})
    assert any(v.startswith("import circle:") for v in violations(tmp_path, "pkg", stages=("core", "fields")))


def test_checker_finds_an_upward_import(tmp_path):
    _write(tmp_path, {**CLEAN, "pkg/core/base.py": "from pkg.fields.a import unit\n"})
    found = violations(tmp_path, "pkg", stages=("core", "fields"))
    assert any(v.startswith("upward import: pkg.core.base") for v in found)


def test_checker_finds_a_private_import(tmp_path):
    _write(tmp_path, {**CLEAN, "pkg/fields/a.py": "from pkg.core.base import _hidden\n"})
    found = violations(tmp_path, "pkg", stages=("core", "fields"))
    assert found == ["private import: pkg.fields.a:1 imports _hidden from pkg.core.base"]


@pytest.mark.parametrize("reason, ok", [("", False), ("  # deferred import: matplotlib costs 0.4 s at start", True)])
def test_checker_finds_a_hidden_import(tmp_path, reason, ok):
    _write(tmp_path, {**CLEAN, "pkg/fields/a.py": f"def f():\n    from pkg.core.base import unit{reason}\n"})
    found = violations(tmp_path, "pkg", stages=("core", "fields"))
    assert (found == []) == ok
