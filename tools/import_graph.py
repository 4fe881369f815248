#!/usr/bin/env python3
"""The import graph of the workspace's library code, and its cycles.

Nodes are source files of each crate's library (src/**/*.rs) and the crates themselves.
A file imports another when it names an item of it: `use crate::a::b`, `crate::a::b(..)`,
`super::x`, `self::x`, or an item the crate root re-exports (`use crate::Foo` where
lib.rs has `pub use a::Foo`: an edge to a.rs, the root being only a list of re-exports).
A crate imports another when its Cargo.toml depends on it ([dependencies] only).

    python3 tools/import_graph.py            # prints the cycles, exit 1 if there are any
    python3 tools/import_graph.py --edges    # also every file-level edge

No third-party packages; CI runs it (.ci/run).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CRATES = {  # crate dir -> crate name as used in paths
    ".": "centaur",
    "lab": "centaur_lab",
    "dynamics": "centaur_dynamics",
    "gym": "centaur_gym",
    "mpc": "centaur_mpc",
    "rl": "centaur_rl",
    "envs": "centaur_envs",
    "python": "_native",
}


def strip_comments(text: str) -> str:
    """Comments out, and the unit tests too: a `#[cfg(test)]` module (last in a file, by
    the workspace's convention) is test code, and its `super` is the file's own module."""
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    cut = text.find("#[cfg(test)]")
    return text if cut < 0 else text[:cut]


def module_files(src: Path) -> dict[tuple[str, ...], Path]:
    """Module path (relative to the crate root) -> file."""
    out = {(): src / "lib.rs"}
    for f in src.rglob("*.rs"):
        rel = f.relative_to(src)
        if rel.parts[0] == "bin" or f.name == "lib.rs":
            continue
        parts = list(rel.with_suffix("").parts)
        if parts[-1] == "mod":
            parts.pop()
        out[tuple(parts)] = f
    return out


def reexports(lib_text: str) -> dict[str, tuple[str, ...]]:
    """Names the crate root re-exports -> the module path they come from."""
    out = {}
    for m in re.finditer(r"pub use\s+([a-z_][a-z0-9_]*(?:::[a-z_][a-z0-9_]*)*)::(\{[^}]*\}|[A-Za-z_0-9]+)\s*;", lib_text):
        path = tuple(m.group(1).split("::"))
        items = m.group(2).strip("{}")
        for item in items.split(","):
            item = item.strip()
            if not item:
                continue
            name = item.split(" as ")[-1].strip()
            out[name] = path
    return out


def resolve(mods: dict, path: tuple[str, ...]) -> Path | None:
    """The file of the longest module prefix of `path`."""
    for k in range(len(path), -1, -1):
        if path[:k] in mods and k > 0:
            return mods[path[:k]]
    return None


def file_edges(crate_dir: Path) -> dict[Path, set[Path]]:
    src = crate_dir / "src"
    mods = module_files(src)
    module_of = {f: m for m, f in mods.items()}
    # Re-exports of every directory module's root (lib.rs, mod.rs): name -> module path.
    roots: dict[tuple[str, ...], dict[str, tuple[str, ...]]] = {}
    for m, f in mods.items():
        if f.name in ("lib.rs", "mod.rs"):
            roots[m] = {k: m + v for k, v in reexports(strip_comments(f.read_text())).items()}

    def target_of(path: tuple[str, ...]) -> Path | None:
        # Follow re-exports: `a::Name` where a's root re-exports Name from a child.
        for k in range(len(path), 0, -1):
            prefix, rest = path[:k - 1], path[k - 1:]
            if prefix in roots and rest[0] in roots[prefix] and (prefix + rest[:1]) not in mods:
                return target_of(roots[prefix][rest[0]] + rest[1:])
        return resolve(mods, path)

    edges: dict[Path, set[Path]] = {f: set() for f in mods.values()}
    ident = r"[A-Za-z_][A-Za-z0-9_]*"
    for f, mod in module_of.items():
        if f.name == "lib.rs":
            continue
        text = strip_comments(f.read_text())
        targets: set[tuple[str, ...]] = set()
        # expand `use a::{b, c::d}` one level
        for m in re.finditer(r"\buse\s+((?:crate|super|self)(?:::\w+)*)::\{([^;]*)\};", text, flags=re.S):
            base = m.group(1)
            for item in re.split(r",(?![^{]*\})", m.group(2)):
                item = item.strip().split(" as ")[0].strip()
                if item:
                    targets.add(tuple((base + "::" + item.split("::{")[0]).split("::")))
        for m in re.finditer(rf"\b((?:crate|super|self)(?:::{ident})+)", text):
            targets.add(tuple(m.group(1).split("::")))
        if f.name == "mod.rs":
            # A directory module's root names its children without a prefix (`child::item`,
            # `pub use child::{..}`): those are edges too.
            children = {m[-1] for m in mods if len(m) == len(mod) + 1 and m[:len(mod)] == mod}
            for m in re.finditer(rf"(?<![:\w])({ident})::({ident}(?:::{ident})*)", text):
                if m.group(1) in children:
                    targets.add(("self", m.group(1)) + tuple(m.group(2).split("::")))
            for m in re.finditer(rf"\buse\s+({ident})::\{{([^;]*)\}};", text, flags=re.S):
                if m.group(1) in children:
                    for item in m.group(2).split(","):
                        item = item.strip().split(" as ")[0].strip()
                        if item:
                            targets.add(("self", m.group(1), item))
        for t in targets:
            parts = list(t)
            if parts[0] == "crate":
                path = parts[1:]
            else:
                # `super` from a file is its parent module; from a mod.rs, its parent's parent.
                base = list(mod)
                while parts and parts[0] in ("super", "self"):
                    if parts[0] == "super":
                        base = base[:-1]
                    parts = parts[1:]
                path = base + parts
            path = tuple(path)
            if not path:
                continue
            target = target_of(path)
            if target is not None and target != f and target.name != "lib.rs":
                edges[f].add(target)
    return edges


def crate_edges() -> dict[str, set[str]]:
    out = {}
    for d, name in CRATES.items():
        toml = (ROOT / d / "Cargo.toml").read_text()
        deps = re.search(r"^\[dependencies\]\n(.*?)(^\[|\Z)", toml, flags=re.S | re.M)
        found = set()
        if deps:
            for other, oname in CRATES.items():
                dash = oname.replace("_", "-")
                if oname != name and re.search(rf"^{dash}\s*[.=]", deps.group(1), flags=re.M):
                    found.add(oname)
        out[name] = found
    return out


def cycles(edges: dict) -> list[list]:
    """Elementary cycles through Tarjan's strongly connected components (each SCC with
    more than one node, or a self-loop, is reported with one cycle through it)."""
    index, low, on, stack, sccs = {}, {}, set(), [], []
    counter = [0]

    def strong(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                strong(w)
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
                sccs.append(comp)

    sys.setrecursionlimit(10000)
    for v in list(edges):
        if v not in index:
            strong(v)
    out = []
    for comp in sccs:
        members = set(comp)
        # one cycle: walk from the first node inside the component back to it
        start = comp[0]
        path, seen = [start], {start}
        node = start
        while True:
            nxt = next((w for w in edges[node] if w in members and (w == start or w not in seen)), None)
            if nxt is None or nxt == start:
                break
            path.append(nxt)
            seen.add(nxt)
            node = nxt
        out.append(path + [start])
    return out


def main() -> int:
    show_edges = "--edges" in sys.argv
    found = 0
    ce = crate_edges()
    for cyc in cycles(ce):
        print("crate cycle: " + " -> ".join(cyc))
        found += 1
    for d in CRATES:
        edges = file_edges(ROOT / d)
        rel = lambda p: str(p.relative_to(ROOT))  # noqa: E731
        if show_edges:
            for f, ts in sorted(edges.items()):
                for t in sorted(ts):
                    print(f"{rel(f)} -> {rel(t)}")
        for cyc in cycles(edges):
            print("file cycle: " + " -> ".join(rel(p) for p in cyc))
            found += 1
    if found:
        print(f"{found} import cycle(s)")
        return 1
    print("no import cycles (crates: " + ", ".join(f"{k} -> {sorted(v)}" for k, v in ce.items() if v) + ")")
    return 0


if __name__ == "__main__":
    sys.exit(main())
