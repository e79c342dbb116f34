"""The package's import graph, read from the source (ast), imports inside functions included:
it has no cycle, and the numerical layers (core, mesh, brep) import nothing from the layers
above them (app, gui, batch, studies, cli). The one exception is FreeCAD's convention of
importing a view provider on the App side under `if FreeCAD.GuiUp:`. Inside brep, each
subpackage imports only the layers below it (BREP_LAYERS), and none imports the run (the
modules at brep/ level)."""
import ast
import os

import pytest

ROOT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "hullprod_wb")
LOWER = ("core", "mesh", "brep")
UPPER = ("app", "gui", "batch", "studies", "cli")
#: What each brep subpackage may import besides itself: package modules outside brep (of
#: these layers or top-level modules such as freecad_env) and the brep subpackages listed.
BREP_LAYERS = {
    "cubature": {"outside": ("core",), "brep": ()},
    "reading": {"outside": ("core", "freecad_env"), "brep": ()},
    "geometry": {"outside": ("core",), "brep": ("reading", "cubature")},
    "validity": {"outside": ("core",), "brep": ("reading", "geometry", "cubature")},
}


def _module_name(path):
    rel = os.path.relpath(path, os.path.dirname(ROOT))[:-3].split(os.sep)
    return ".".join(rel[:-1] if rel[-1] == "__init__" else rel)


def _is_gui_guard(node):
    """`if FreeCAD.GuiUp:` or `if FreeCAD.GuiUp and ...:`."""
    test = node.test
    if isinstance(test, ast.BoolOp) and isinstance(test.op, ast.And):
        test = test.values[0]
    return isinstance(test, ast.Attribute) and test.attr == "GuiUp"


def _imports(tree, module, is_package, modules):
    """Package modules (of modules) that module imports, skipping those under a GuiUp guard."""
    base = module.split(".") if is_package else module.split(".")[:-1]
    found = set()

    def visit(node):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _is_gui_guard(child):
                for other in child.orelse:
                    visit_one(other)
                continue
            visit_one(child)

    def visit_one(node):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.split(".")[0] == "hullprod_wb")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                stem = base[:len(base) - node.level + 1]
                target = ".".join(stem + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] == "hullprod_wb":
                for a in node.names:  # a name that is a submodule, else the module itself
                    found.add(target + "." + a.name if target + "." + a.name in modules else target)
        visit(node)

    visit(tree)
    return found


def import_graph():
    """{module: set of package modules it imports}, names resolved to existing modules."""
    sources = {}
    for folder, _, files in os.walk(ROOT):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                sources[_module_name(path)] = path
    graph = {}
    for name, path in sources.items():
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), path)
        raw = _imports(tree, name, path.endswith("__init__.py"), sources)
        graph[name] = {m for m in raw if m in sources and m != name}
    return graph


def _cycle(graph):
    """One import cycle as a list of modules, or None (iterative depth-first search)."""
    colour, parent = {}, {}
    for start in sorted(graph):
        if start in colour:
            continue
        stack = [(start, iter(sorted(graph[start])))]
        colour[start] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                colour[node] = 2
                stack.pop()
                continue
            if colour.get(nxt) == 1:
                path = [node]
                while path[-1] != nxt:
                    path.append(parent[path[-1]])
                return path[::-1] + [nxt]
            if nxt not in colour:
                colour[nxt], parent[nxt] = 1, node
                stack.append((nxt, iter(sorted(graph[nxt]))))
    return None


def _layer(module):
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_the_graph_is_read():
    graph = import_graph()
    assert "hullprod_wb.brep.backend" in graph["hullprod_wb.api"] or \
        any(m.startswith("hullprod_wb.brep") for m in graph["hullprod_wb.api"])
    assert "hullprod_wb.core.errors" in graph["hullprod_wb.brep.geometry.nurbs"]
    assert "hullprod_wb.brep.cubature.roots" in graph["hullprod_wb.brep.geometry.trimmed_domain"]


def test_no_import_cycle():
    cycle = _cycle(import_graph())
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_a_cycle_is_found():
    assert _cycle({"p.a": {"p.b"}, "p.b": {"p.c"}, "p.c": {"p.a"}}) == ["p.a", "p.b", "p.c", "p.a"]
    assert _cycle({"p": {"p.a"}, "p.a": {"p"}}) == ["p", "p.a", "p"]
    assert _cycle({"p": {"p.a", "p.b"}, "p.a": {"p.b"}, "p.b": set()}) is None


@pytest.mark.parametrize("layer", LOWER)
def test_numerical_layers_import_nothing_above_them(layer):
    graph = import_graph()
    wrong = sorted("%s -> %s" % (m, t) for m, targets in graph.items() if _layer(m) == layer
                   for t in targets if _layer(t) in UPPER)
    assert wrong == []


def _brep_part(module):
    """The brep subpackage of a module ('cubature', 'reading', ...), 'run' for the modules at
    brep/ level, None outside brep."""
    parts = module.split(".")
    if parts[1:2] != ["brep"]:
        return None
    return parts[2] if len(parts) > 2 and parts[2] in BREP_LAYERS else "run"


def _allowed(part, target):
    """Whether a module of the brep subpackage part may import target."""
    other = _brep_part(target)
    if other is None:
        return target.split(".")[1] in BREP_LAYERS[part]["outside"]
    return other == part or other in BREP_LAYERS[part]["brep"]


def test_brep_is_in_subpackages():
    graph = import_graph()
    assert {_brep_part(m) for m in graph} == set(BREP_LAYERS) | {"run", None}
    run = sorted(m.rsplit(".", 1)[1] for m in graph if _brep_part(m) == "run" and m != "hullprod_wb.brep")
    assert len(run) <= 8, run  # the run and its face pipeline, the rest in the subpackages


@pytest.mark.parametrize("part", sorted(BREP_LAYERS))
def test_brep_subpackages_import_only_the_layers_below(part):
    graph = import_graph()
    wrong = sorted("%s -> %s" % (m, t) for m, targets in graph.items() if _brep_part(m) == part
                   for t in targets if not _allowed(part, t))
    assert wrong == []


def test_the_layer_rule_catches_a_wrong_import():
    assert _allowed("cubature", "hullprod_wb.core.errors")
    assert not _allowed("cubature", "hullprod_wb.brep.geometry.nurbs")
    assert not _allowed("geometry", "hullprod_wb.brep.validity.singular")
    assert not _allowed("validity", "hullprod_wb.brep.face_setup")
    assert not _allowed("reading", "hullprod_wb.mesh.readers")
    assert _allowed("validity", "hullprod_wb.brep.cubature")
