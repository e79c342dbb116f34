"""The package's shape, read from the source (ast): no module over MAX_MODULE_LINES lines, no
function of brep over MAX_FUNCTION_LINES lines, no class with more than one base from the
package (no mixins), and no private name (a leading underscore) imported from another
module of brep."""
import ast
import functools
import os

import pytest

ROOT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "hullprod_wb")
MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 80


@functools.lru_cache(maxsize=None)
def _sources(folder=ROOT):
    """{path relative to hullprod_wb: parsed tree} of the package's modules under folder."""
    out = {}
    for here, _, files in os.walk(folder):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(here, f)
                with open(path, encoding="utf-8") as fh:
                    text = fh.read()
                out[os.path.relpath(path, ROOT)] = (text, ast.parse(text, path))
    return out


def long_functions(trees, limit=MAX_FUNCTION_LINES):
    """'module:function lines' of the functions (methods included) longer than limit lines."""
    return sorted("%s:%s %d" % (m, n.name, n.end_lineno - n.lineno + 1) for m, (_, t) in trees.items()
                  for n in ast.walk(t) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
                  and n.end_lineno - n.lineno + 1 > limit)


def package_names(tree):
    """Names a module imports from the package (relative imports or hullprod_wb...)."""
    return {a.asname or a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
            and (n.level or (n.module or "").startswith("hullprod_wb")) for a in n.names}


def test_no_module_is_too_long():
    long = sorted("%s %d" % (m, text.count("\n")) for m, (text, _) in _sources().items()
                  if text.count("\n") > MAX_MODULE_LINES)
    assert long == []


def test_no_brep_function_is_too_long():
    assert long_functions(_sources(os.path.join(ROOT, "brep"))) == []


def test_a_long_function_is_found():
    body = "\n".join("    x = %d" % i for i in range(MAX_FUNCTION_LINES))
    tree = ast.parse("def f():\n" + body + "\n\ndef g():\n    return 1\n")
    assert long_functions({"m.py": ("", tree)}) == ["m.py:f %d" % (MAX_FUNCTION_LINES + 1)]


@pytest.mark.parametrize("module", sorted(_sources()))
def test_no_class_has_two_package_bases(module):
    _, tree = _sources()[module]
    own = package_names(tree) | {n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)}
    mixed = [n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)
             and sum(isinstance(b, ast.Name) and b.id in own for b in n.bases) > 1]
    assert mixed == []


def test_no_private_name_crosses_brep_modules():
    crossing = sorted("%s: %s" % (m, a.name) for m, (_, t) in _sources(os.path.join(ROOT, "brep")).items()
                      for n in ast.walk(t) if isinstance(n, ast.ImportFrom) and n.level
                      for a in n.names if a.name.startswith("_"))
    assert crossing == []
