"""The crate's files import each other one way: no circle in the file-level graph of `src/`.

Inside the crate every item is named by its home module: a path through the crate root's
re-exports (`use crate::Scalar`) would be an arrow to `lib.rs`, which sits above everything it
re-exports, and fails `test_no_internal_import_of_a_root_reexport`.

An arrow runs from a file to each file whose items it names: `crate::`, `super::`, `self::` and
child-module paths, in `use` declarations and in code (inline modules such as `mod tests`
included), with re-exports (`pub use`) followed to the file that defines the item. A `pub use` line is
not an arrow of its own (its importers get the arrow to the defining file); anything else a
`mod.rs` defines and its children use is. Comments and strings are left out. The same graph between
top-level folders ("rooms") must follow the layer order of docs/ARCHITECTURE.md.
"""

import re
from pathlib import Path
from typing import Dict, List, Optional, Set, Tuple

SRC = Path(__file__).resolve().parents[2] / "src"
Module = Tuple[str, ...]

# Bottom to top: a room may name only rooms at or below its own position.
LAYERS = [
    "error", "scalar", "rigid", "checks", "linalg", "nonlinear", "energies", "eom", "dynamics", "expr",
    "program", "native", "taylor", "derived", "routes", "tape", "constrained",
    "integrators", "statics", "sensitivity", "trace",
    "scenes", "python", "tests",
]


def _strip(text: str) -> str:
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r'r(#*)".*?"\1', '""', text, flags=re.S)
    text = re.sub(r"'(?:\\.|[^'\\])'", "' '", text)
    text = re.sub(r'"(?:\\[\s\S]|[^"\\])*"', '""', text)
    return re.sub(r"//[^\n]*", "", text)


def _module(path: Path) -> Module:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return tuple(parts[:-1] if parts[-1] in ("mod", "lib") else parts)


FILES: Dict[Module, Path] = {_module(p): p for p in SRC.rglob("*.rs")}
TEXTS: Dict[Module, str] = {m: _strip(p.read_text()) for m, p in FILES.items()}


def _expand(tree: str) -> List[str]:
    """`a::{b, c::{d, e}}` as `a::b`, `a::c::d`, `a::c::e`."""
    i = tree.find("{")
    if i < 0:
        return [tree]
    parts, depth, cur = [], 0, ""
    for ch in tree[i + 1:tree.rfind("}")]:
        depth += (ch == "{") - (ch == "}")
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    return [tree[:i] + e for p in parts if p for e in _expand(p)]


def _uses(text: str) -> List[Tuple[bool, str]]:
    found = []
    for m in re.finditer(r"\b(pub(?:\([^)]*\))?\s+)?use\s+([^;]+);", text):
        tree = re.sub(r"\s*(::|[{},])\s*", r"\1", re.sub(r"\s+", " ", m.group(2).strip()))
        for path in _expand(tree):
            found.append((bool(m.group(1)), path))
    return found


def _absolute(m: Module, path: str) -> Optional[List[str]]:
    segs = [s.split(" as ")[0] for s in path.split("::")]
    if segs[0] == "crate":
        base, rest = (), segs[1:]
    elif segs[0] in ("super", "self"):
        base, rest = m, segs
        while rest and rest[0] in ("super", "self"):
            base = base[:-1] if rest[0] == "super" else base
            rest = rest[1:]
    elif m + (segs[0],) in FILES:
        base, rest = m, segs
    else:
        return None
    return list(base) + [s for s in rest if s]


def _reexports(m: Module) -> Dict[str, List[str]]:
    names: Dict[str, List[str]] = {}
    for public, path in _uses(TEXTS[m]):
        target = _absolute(m, path)
        last = path.split("::")[-1]
        if not public or target is None or last == "*":
            continue
        alias = re.match(r"(\w+) as (\w+)$", last)
        if alias:
            target[-1] = alias.group(1)
        names[alias.group(2) if alias else last] = target
    return names


REEXPORTS = {m: _reexports(m) for m in FILES}


def _defining_file(path: List[str], depth: int = 0) -> Module:
    cur: Module = ()
    i = 0
    while i < len(path) and cur + (path[i],) in FILES:
        cur += (path[i],)
        i += 1
    target = REEXPORTS.get(cur, {}).get(path[i]) if i < len(path) else None
    if target is not None and depth < 16 and target + path[i + 1:] != path:
        return _defining_file(target + path[i + 1:], depth + 1)
    return cur


def _inline_modules_as_self(text: str) -> str:
    """`super::` inside an inline `mod x { … }` names the file's own module."""
    for start in reversed([m.end() for m in re.finditer(r"\bmod\s+\w+\s*\{", text)]):
        depth, end = 1, start
        while end < len(text) and depth:
            depth += (text[end] == "{") - (text[end] == "}")
            end += 1
        text = text[:start] + re.sub(r"\bsuper::", "self::", text[start:end]) + text[end:]
    return text


def file_graph() -> Dict[Module, Set[Module]]:
    graph: Dict[Module, Set[Module]] = {m: set() for m in FILES}
    for m, raw in TEXTS.items():
        text = _inline_modules_as_self(raw)
        paths = {p for public, p in _uses(text) if not public}
        code = re.sub(r"\buse\s+[^;]+;", "", text)
        paths |= {x.group(1) for x in re.finditer(r"(?<![\w:])((?:crate|super|self)(?:::\w+)+)", code)}
        paths |= {x.group(1) for x in re.finditer(r"(?<![\w:])(\w+(?:::\w+)+)", code)
                  if m + (x.group(1).split("::")[0],) in FILES}
        for path in paths:
            absolute = _absolute(m, path)
            if absolute is not None:
                target = _defining_file(absolute)
                if target not in ((), m):
                    graph[m].add(target)
    return graph


def _cycles(graph: Dict[Module, Set[Module]]) -> List[List[Module]]:
    """Strongly connected components of more than one file (Tarjan, iteratively)."""
    index: Dict[Module, int] = {}
    low: Dict[Module, int] = {}
    stack: List[Module] = []
    on_stack: Set[Module] = set()
    found: List[List[Module]] = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            v, children = work[-1]
            w = next(children, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                component = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    component.append(w)
                    if w == v:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def _name(m: Module) -> str:
    return "src/" + "/".join(m) if m else "src/lib.rs"


def test_the_analysis_sees_arrows() -> None:
    graph = file_graph()
    assert ("error",) in graph[("dynamics",)] or any(("error",) in d for d in graph.values())
    assert sum(len(d) for d in graph.values()) > 100


def test_no_import_circle_between_files() -> None:
    graph = file_graph()
    report = []
    for component in _cycles(graph):
        arrows = [f"{_name(a)} → {_name(b)}" for a in component for b in sorted(graph[a]) if b in component]
        report.append("circle: " + ", ".join(arrows))
    assert not report, "\n".join(report)


def test_rooms_follow_the_layers() -> None:
    graph = file_graph()
    up = []
    for m, deps in graph.items():
        for d in deps:
            a, b = (m[0] if m else "lib"), d[0]
            if a == b or a == "lib":
                continue
            assert a in LAYERS and b in LAYERS, f"room {a!r} or {b!r} is not in LAYERS"
            if LAYERS.index(b) > LAYERS.index(a):
                up.append(f"{_name(m)} → {_name(d)}")
    assert not up, "arrows running up the layers:\n" + "\n".join(sorted(up))


def _paths(m: Module) -> Set[str]:
    """Every path file `m` names: in `use` declarations (public ones included) and in code."""
    text = _inline_modules_as_self(TEXTS[m])
    paths = {p for _, p in _uses(text)}
    code = re.sub(r"\buse\s+[^;]+;", "", text)
    paths |= {x.group(1) for x in re.finditer(r"(?<![\w:$])((?:crate|super|self)(?:::\w+)+)", code)}
    return paths


def root_reexport_imports() -> List[str]:
    """The places inside the crate that name an item through a crate-root re-export."""
    root = REEXPORTS[()]
    found = []
    for m in FILES:
        if m == ():
            continue
        for path in sorted(_paths(m)):
            absolute = _absolute(m, path)
            if absolute and absolute[0] in root and (absolute[0],) not in FILES:
                found.append(f"{_name(m)}: {path} (name it by its home, crate::{'::'.join(root[absolute[0]])})")
    return found


def test_the_reexport_check_sees_a_root_import() -> None:
    saved = TEXTS[("dynamics",)]
    try:
        TEXTS[("dynamics",)] = saved + "\nuse crate::Scalar;\nfn f() -> crate::Error { todo!() }\n"
        found = root_reexport_imports()
    finally:
        TEXTS[("dynamics",)] = saved
    assert any("crate::Scalar" in f for f in found) and any("crate::Error" in f for f in found)


def test_no_internal_import_of_a_root_reexport() -> None:
    found = root_reexport_imports()
    assert not found, "imports through the crate root's re-exports:\n" + "\n".join(found)
