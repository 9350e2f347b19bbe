#!/usr/bin/env python3
"""The layering of vkmech's C++ sources (docs/architecture.md), checked.

    check_layers.py [ROOT]          check the tree at ROOT (default: the repository)
    check_layers.py --graph [ROOT]  print the module graph and exit 0
    check_layers.py --self-test     show that each rule fails on a tree that breaks it

Every source file belongs to one module, the folder under its layer's root:

    engine    host/engine/<module>/   vk, scene, accel, render, io
    analysis  analysis/<module>/      stats, report, allocation, experiments
    app       host/app/<module>/      cli, study, adaptive
    shaders   shaders/                the GLSL/C++ shared headers

Rules (exit 1 and one line per violation when broken):
  1. A file includes only from its own layer or a layer below it
     (shaders < engine < analysis < app).
  2. No file of the analysis layer or of the engine's Vulkan-free modules
     (io, scene, accel) reaches Vulkan: neither it nor anything it includes,
     transitively, includes <vulkan/...>.
  3. The module graph (an edge for every include between two modules) has no
     cycle.
The build itself enforces rule 2: the Vulkan-free libraries (vkmech_io,
vkmech_scene, vkmech_accel, vkmech_frame) and vkmech_analysis link no
Vulkan and compile with host/vulkan_free/ first on their include path,
whose <vulkan/...> headers are #error. The CMake targets (each layer with
its own include root) also refuse rule 1 at compile time for most includes;
this script states all three rules in one place and runs as a ctest entry.
"""
import os
import re
import sys
import tempfile

LAYERS = [("shaders", "shaders"), ("engine", "host/engine"), ("analysis", "analysis"), ("app", "host/app")]
RANK = {name: i for i, (name, _) in enumerate(LAYERS)}
VULKAN_FREE_ENGINE = {"io", "scene", "accel"}  # the engine modules with a Vulkan-free library (CMakeLists.txt)
SUFFIXES = (".cpp", ".hpp", ".h", ".glsl")
QUOTED = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
ANGLED = re.compile(r'^\s*#\s*include\s+<([^>]+)>', re.M)


def classify(rel):
    """(layer, module) of a repository-relative path, or None."""
    for layer, root in reversed(LAYERS):  # host/app before host/...
        if rel.startswith(root + "/"):
            rest = rel[len(root) + 1:]
            module = "shaders" if layer == "shaders" else rest.split("/")[0]
            if layer != "shaders" and "/" not in rest:
                module = "(top)"
            return layer, module
    return None


def collect(root):
    files = {}
    for layer, base in LAYERS:
        top = os.path.join(root, base)
        for dirpath, _, names in os.walk(top):
            for n in names:
                if n.endswith(SUFFIXES):
                    full = os.path.join(dirpath, n)
                    rel = os.path.relpath(full, root).replace(os.sep, "/")
                    with open(full, encoding="utf-8", errors="replace") as fh:
                        files[rel] = fh.read()
    return files


def resolve(root, files, src, inc):
    """The repository-relative file an include names: its own folder first, then each layer's root."""
    here = os.path.dirname(src)
    for base in [here] + [b for _, b in LAYERS]:
        cand = os.path.normpath(os.path.join(base, inc)).replace(os.sep, "/")
        if cand in files:
            return cand
    return None  # a system header or a generated one (shaders/spv_*.h)


def check(root):
    files = collect(root)
    edges = {}  # src -> [resolved includes]
    for src, text in files.items():
        edges[src] = [r for r in (resolve(root, files, src, i) for i in QUOTED.findall(text)) if r]
    problems = []
    # 1. layer order
    for src, incs in edges.items():
        ls, _ = classify(src)
        for dst in incs:
            ld, _ = classify(dst)
            if RANK[ld] > RANK[ls]:
                problems.append(f"{src}: includes {dst}: the {ls} layer may not use the {ld} layer above it")
    # 2. no Vulkan in analysis or the engine's Vulkan-free modules, transitively
    vulkan_direct = {f for f, t in files.items() if any(a.startswith("vulkan/") for a in ANGLED.findall(t))}
    for src in sorted(edges):
        layer, module = classify(src)
        if layer != "analysis" and not (layer == "engine" and module in VULKAN_FREE_ENGINE):
            continue
        seen, stack, parent = {src}, [src], {src: None}
        while stack:
            f = stack.pop()
            if f in vulkan_direct:
                chain = []
                while f is not None:
                    chain.append(f)
                    f = parent[f]
                problems.append(f"{src}: reaches Vulkan through " + " -> ".join(reversed(chain)) + " -> <vulkan/...>")
                break
            for g in edges.get(f, []):
                if g not in seen:
                    seen.add(g)
                    parent[g] = f
                    stack.append(g)
    # 3. no cycle between modules
    graph = {}
    for src, incs in edges.items():
        a = "/".join(classify(src))
        graph.setdefault(a, set())
        for dst in incs:
            b = "/".join(classify(dst))
            if a != b:
                graph[a].add(b)
                graph.setdefault(b, set())
    for cycle in find_cycles(graph):
        problems.append("module cycle: " + " -> ".join(cycle + [cycle[0]]))
    return problems, graph


def find_cycles(graph):
    """One cycle per strongly connected component larger than one node (Tarjan)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
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
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def self_test():
    """Each rule, broken on purpose in a small tree, must be reported."""
    cases = {
        "layer order": {"host/engine/io/a.hpp": '#include "stats/s.hpp"\n', "analysis/stats/s.hpp": ""},
        "vulkan in analysis": {"analysis/experiments/e.cpp": '#include "render/r.hpp"\n',
                               "host/engine/render/r.hpp": '#include "vk/c.hpp"\n',
                               "host/engine/vk/c.hpp": "#include <vulkan/vulkan.hpp>\n"},
        "vulkan in accel": {"host/engine/accel/a.cpp": '#include "vk/c.hpp"\n',
                            "host/engine/vk/c.hpp": "#include <vulkan/vulkan.hpp>\n"},
        "module cycle": {"host/engine/io/a.hpp": '#include "render/b.hpp"\n',
                         "host/engine/render/b.hpp": '#include "vk/c.hpp"\n',
                         "host/engine/vk/c.hpp": '#include "io/a.hpp"\n'},
    }
    expect = {"layer order": "may not use the analysis layer", "vulkan in analysis": "reaches Vulkan",
              "vulkan in accel": "host/engine/accel/a.cpp: reaches Vulkan",
              "module cycle": "module cycle: engine/io -> engine/render -> engine/vk -> engine/io"}
    failed = 0
    for name, tree in cases.items():
        with tempfile.TemporaryDirectory() as d:
            for rel, text in tree.items():
                os.makedirs(os.path.join(d, os.path.dirname(rel)), exist_ok=True)
                with open(os.path.join(d, rel), "w") as fh:
                    fh.write(text)
            problems, _ = check(d)
            hit = any(expect[name] in p for p in problems)
            print(f"self-test {name}: {'reported' if hit else 'NOT reported'}: {problems}")
            failed += not hit
    # and a tree that keeps every rule passes
    with tempfile.TemporaryDirectory() as d:
        tree = {"host/engine/io/a.hpp": "", "host/engine/render/b.hpp": '#include "io/a.hpp"\n',
                "analysis/stats/s.hpp": '#include "io/a.hpp"\n', "host/app/cli/m.cpp": '#include "stats/s.hpp"\n'}
        for rel, text in tree.items():
            os.makedirs(os.path.join(d, os.path.dirname(rel)), exist_ok=True)
            with open(os.path.join(d, rel), "w") as fh:
                fh.write(text)
        problems, _ = check(d)
        print(f"self-test clean tree: {problems or 'no violation'}")
        failed += bool(problems)
    return 1 if failed else 0


def main(argv):
    if "--self-test" in argv:
        return self_test()
    args = [a for a in argv if not a.startswith("--")]
    root = args[0] if args else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    problems, graph = check(root)
    if "--graph" in argv:
        for a in sorted(graph, key=lambda m: (RANK[m.split("/")[0]], m)):
            print(f"{a}: {', '.join(sorted(graph[a])) or '-'}")
        return 0
    for p in problems:
        print("layers: " + p)
    n = sum(1 for _ in graph)
    print(f"layers: {len(problems)} violation(s) among {n} modules")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
