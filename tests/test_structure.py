"""The house rules that can be read off the source (issue #18, "How we will check it").

No module over ~400 lines, no function over ~80 (GLSL included), no brace crossing a preprocessor
branch in the shaders, no import cycle among mcpt's modules, no test reading a folder outside the
repository. Each failure lists every offender with its file and line.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from .conftest import ROOT

# The issue says "~400" and "~80": a little slack, so that a line of margin does not fail CI.
MAX_MODULE_LINES = 420
MAX_FUNCTION_LINES = 80
# Source folder -> its name in the installed package (pyproject.toml / setup.py).
PACKAGES = {"mcpt": "mcpt", "cli": "mcpt.cli", "bench": "mcpt.bench"}
GLSL = ROOT / "glsl"


def _python_files():
    for folder in PACKAGES:
        yield from sorted((ROOT / folder).rglob("*.py"))


def _shader_files():
    return sorted(p for p in GLSL.rglob("*") if p.suffix in (".glsl", ".frag", ".vert"))


def _rel(p: Path) -> str:
    return p.relative_to(ROOT).as_posix()


# ------------------------------------------------------------------------------------------------
# Sizes
# ------------------------------------------------------------------------------------------------

def test_no_module_over_400_lines():
    files = list(_python_files()) + _shader_files()
    long = [f"{_rel(p)}: {n} lines" for p in files
            if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES]
    assert not long, f"modules over {MAX_MODULE_LINES} lines:\n" + "\n".join(long)


def test_no_python_function_over_80_lines():
    long = []
    for p in _python_files():
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{_rel(p)}:{node.lineno}: {node.name} ({n} lines)")
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines:\n" + "\n".join(long)


# ------------------------------------------------------------------------------------------------
# GLSL: functions and braces, read with the preprocessor's branches in view
# ------------------------------------------------------------------------------------------------

_DIRECTIVE = re.compile(r"^\s*#\s*(\w+)")


def _code_lines(text: str) -> list[str]:
    """The shader's lines with comments blanked (line numbers kept) and continued directives
    joined onto their first line."""
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group().count("\n"), text, flags=re.S)
    lines = [re.sub(r"//.*", "", ln) for ln in text.splitlines()]
    i = 0
    while i < len(lines):
        j = i
        while lines[i].rstrip().endswith("\\") and j + 1 < len(lines):
            j += 1
            lines[i] = lines[i].rstrip()[:-1] + " " + lines[j]
            lines[j] = ""
        i = j + 1
    return lines


def glsl_structure(text: str):
    """(functions, crossings) of one shader source.

    functions: (name, first line, last line) of each top-level function body; crossings: one
    message per preprocessor branch whose braces do not balance. Each branch of an
    #if/#elif/#else chain starts at the brace depth of its #if; after #endif the depth is that at
    the end of the first branch, so one configuration is followed and the others are checked."""
    functions, crossings = [], []
    depth, stack = 0, []           # stack: [line of #if, depth at #if, depth after 1st branch]
    start = name = None
    pending = ""                   # text since the last top-level ; or } (a signature builds up)
    pending_line = 0
    for no, ln in enumerate(_code_lines(text), 1):
        d = _DIRECTIVE.match(ln)
        if d:
            kw = d.group(1)
            if kw in ("if", "ifdef", "ifndef"):
                stack.append([no, depth, None])
            elif kw in ("elif", "else", "endif") and stack:
                top = stack[-1]
                if depth != top[1]:
                    crossings.append(f"line {no} (#{kw} of the #if at line {top[0]}): the branch "
                                     f"{'opens' if depth > top[1] else 'closes'} "
                                     f"{abs(depth - top[1])} brace(s) it does not "
                                     f"{'close' if depth > top[1] else 'open'}")
                if top[2] is None:
                    top[2] = depth
                if kw == "endif":
                    depth = stack.pop()[2]
                else:
                    depth = top[1]
            continue
        for ch in ln:
            if ch == "{":
                if depth == 0:
                    m = re.search(r"(\w+)\s*\([^()]*(?:\([^()]*\)[^()]*)*\)\s*$", pending)
                    if m and not re.match(r"\s*(struct|layout|uniform|buffer)\b", pending.strip()):
                        name, start = m.group(1), pending_line or no
                    else:
                        name = start = None
                depth += 1
            elif ch == "}":
                depth -= 1
                if depth == 0:
                    if name is not None:
                        functions.append((name, start, no))
                    name = start = None
                    pending, pending_line = "", 0
            elif depth == 0:
                if ch == ";":
                    pending, pending_line = "", 0
                else:
                    if not pending.strip() and not ch.isspace():
                        pending_line = no
                    pending += ch
        if depth == 0:
            pending += " "
    return functions, crossings


def test_glsl_structure_reader_finds_what_it_should():
    src = """
struct S { float x; };
vec3 f(vec3 a,
       float b) {
    if (b > 0.0) { return a; }
    return -a;
}
#if MCPT_X
void g() { return; }
#else
void g() { }
#endif
#define M(x) \\
    { x; }
#if MCPT_Y
void h() {
#endif
}
"""
    functions, crossings = glsl_structure(src)
    assert functions == [("f", 3, 7), ("g", 9, 9), ("g", 11, 11), ("h", 16, 18)]
    assert len(crossings) == 1 and crossings[0].startswith("line 17 ("), crossings


def test_no_glsl_function_over_80_lines():
    long = []
    for p in _shader_files():
        for name, a, b in glsl_structure(p.read_text())[0]:
            if b - a + 1 > MAX_FUNCTION_LINES:
                long.append(f"{_rel(p)}:{a}: {name} ({b - a + 1} lines)")
    assert not long, f"GLSL functions over {MAX_FUNCTION_LINES} lines:\n" + "\n".join(long)


def test_no_brace_crosses_a_preprocessor_branch():
    bad = [f"{_rel(p)}: {c}" for p in _shader_files() for c in glsl_structure(p.read_text())[1]]
    assert not bad, "braces crossing #if branches:\n" + "\n".join(bad)


# ------------------------------------------------------------------------------------------------
# Imports
# ------------------------------------------------------------------------------------------------

def _module_name(p: Path) -> str:
    folder = p.relative_to(ROOT).parts[0]
    parts = [PACKAGES[folder], *p.relative_to(ROOT / folder).with_suffix("").parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _type_checking_only(tree: ast.AST) -> set[int]:
    """ids of the import nodes under ``if TYPE_CHECKING:`` (annotations only: never run)."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for b in node.body for n in ast.walk(b)}
    return skip


def import_graph() -> dict[str, dict[str, int]]:
    """module -> {imported mcpt module: line}, every import counted (inside functions too), except
    under ``if TYPE_CHECKING:``. ``from a import b`` is an edge to ``a.b`` where that is a module,
    else to ``a``."""
    files = {_module_name(p): p for p in _python_files()}
    graph: dict[str, dict[str, int]] = {}
    for mod, p in files.items():
        tree = ast.parse(p.read_text())
        skip = _type_checking_only(tree)
        package = mod if p.name == "__init__.py" else mod.rpartition(".")[0]
        edges = graph.setdefault(mod, {})
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    pkg = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join(pkg + ([base] if base else []))
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in files else base for a in node.names]
            else:
                continue
            for t in targets:
                while t and t not in files:  # `import mcpt.gpu.x.y`: the deepest module that exists
                    t = t.rpartition(".")[0]
                if t and t != mod:
                    edges.setdefault(t, node.lineno)
    return graph


def import_cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each as (a shortest
    cycle through its first member, the component's other members off that cycle)."""
    index, low, on, stack, comps = {}, {}, set(), [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    cycles = []
    for comp in sorted(comps):  # a shortest way back to the first member, by breadth-first search
        first, members = comp[0], set(comp)
        prev, todo = {first: None}, [first]
        while todo and first not in [w for v in todo for w in graph[v]]:
            nxt = []
            for v in todo:
                for w in sorted(graph[v]):
                    if w in members and w not in prev:
                        prev[w] = v
                        nxt.append(w)
            todo = nxt
        last = next(v for v in todo if first in graph[v])
        path = [last]
        while prev[path[-1]] is not None:
            path.append(prev[path[-1]])
        cycles.append((path[::-1] + [first], sorted(members - set(path))))
    return cycles


def test_import_cycle_finder_finds_a_cycle():
    g = {"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}, "d": {"a": 1}}
    assert import_cycles(g) == [(["a", "b", "c", "a"], [])]
    assert import_cycles({"a": {"b": 1}, "b": {}}) == []


def test_no_import_cycle_among_mcpt_modules():
    graph = import_graph()
    assert "mcpt.cli.main" in graph and "mcpt.bench.stability.core" in graph  # the mapped folders
    cycles = import_cycles(graph)

    def hop(a, b):
        return f"{a} (line {graph[a][b]})" if b in graph.get(a, {}) else a

    lines = [" -> ".join(hop(c[i], c[i + 1]) if i + 1 < len(c) else c[i] for i in range(len(c)))
             + (f"; in the same knot: {', '.join(rest)}" if rest else "") for c, rest in cycles]
    assert not cycles, "import cycles (module (line of the import) -> ...):\n" + "\n".join(lines)


# ------------------------------------------------------------------------------------------------
# Tests stand on their own
# ------------------------------------------------------------------------------------------------

def _outside_paths(tree: ast.AST) -> list[tuple[int, str]]:
    """String constants (docstrings aside) that name a folder outside the repository: the sibling
    ``shared`` folder as a path part, ``..`` climbing out, or an absolute machine path."""
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
            and n.body and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
    hits = []
    for n in ast.walk(tree):
        if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs:
            s = n.value
            if (s == "shared" or re.search(r"(^|/)\.\./|(^|/)shared/|^/(work|home|root|mnt|tmp)/", s)):
                hits.append((n.lineno, s))
    return sorted(hits)


def test_tests_read_nothing_outside_the_repository():
    this = Path(__file__).resolve()
    bad = []
    for p in sorted((ROOT / "tests").rglob("*.py")):
        if p.resolve() == this:
            continue
        tree = ast.parse(p.read_text())
        bad += [f"{_rel(p)}:{line}: {s!r}" for line, s in _outside_paths(tree)]
        # pytest.skip at import time skips a whole module silently (and is a collection error).
        for node in tree.body:
            for call in ast.walk(node):
                if (not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
                        and isinstance(call, ast.Call) and ast.unparse(call.func) == "pytest.skip"):
                    bad.append(f"{_rel(p)}:{call.lineno}: pytest.skip at import time")
    assert not bad, "tests reaching outside the repository:\n" + "\n".join(bad)


def test_outside_path_finder_finds_them():
    src = 'X = Path("/work/shared/a")\nY = ROOT.parent / "shared"\nZ = "../shared/m.obj"\nW = "ok/data"\n'
    assert [line for line, _ in _outside_paths(ast.parse(src))] == [1, 2, 3]
