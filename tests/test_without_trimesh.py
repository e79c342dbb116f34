"""Without trimesh (FreeCAD 0.20 and 1.0.0 installs through the Addon Manager, whose lists of
allowed packages lack it): the workbench loads, the BRep path and the binary mesh formats
work, and a format that needs trimesh is refused with one line saying how to install it.

Each check runs in a process of its own in which `import trimesh` fails (the module is
blocked before anything else is imported) and asserts that it does."""
import os
import re
import shutil
import subprocess
import textwrap

import numpy as np
import pytest

from conftest import ROOT, fresh_user_env, home_with_this_checkout, needs_freecad

#: Prepended to every script: trimesh cannot be imported in this process.
BLOCK = "import sys; sys.modules['trimesh'] = None\n"
PYTHON = "/usr/bin/python3"


def command(*args, cwd=ROOT):
    """./hullprod ARGS with trimesh blocked: the launcher's interpreter, module and settings."""
    script = BLOCK + ("import runpy; sys.argv = ['hullprod'] + sys.argv[1:]; "
                      "runpy.run_module('hullprod_wb.cli', run_name='__main__')")
    env = dict(os.environ, PYTHONPATH=ROOT)
    return subprocess.run([PYTHON, "-P", "-c", script] + list(args), capture_output=True, text=True, cwd=cwd,
                          env=env, timeout=300)


@pytest.fixture(scope="module")
def mesh_files(tmp_path_factory):
    """The same open grid as binary STL, binary PLY and ASCII STL (written without trimesh)."""
    from hullprod_wb.examples.analytic_meshes import saddle_mesh
    from hullprod_wb.selftest import write_binary_ply
    d = tmp_path_factory.mktemp("no_trimesh")
    V, F = saddle_mesh(16)
    tri = np.asarray(V, float)[np.asarray(F)]
    rec = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("c", "<f4", (3, 3)), ("a", "<u2")])
    rec["c"] = tri
    (d / "grid.stl").write_bytes(b"\0" * 80 + np.uint32(len(tri)).tobytes() + rec.tobytes())
    write_binary_ply(str(d / "grid.ply"), V, F)
    lines = ["solid grid"]
    for t in tri:
        lines += ["facet normal 0 0 1", "outer loop"] + ["vertex %.17g %.17g %.17g" % tuple(p) for p in t]
        lines += ["endloop", "endfacet"]
    (d / "grid_ascii.stl").write_text("\n".join(lines + ["endsolid grid", ""]))
    return d


def test_trimesh_is_blocked_in_the_checks():
    r = subprocess.run([PYTHON, "-c", BLOCK + "import trimesh"], capture_output=True, text=True)
    assert r.returncode == 1 and ("ModuleNotFoundError" in r.stderr or "ImportError" in r.stderr), r.stderr


@needs_freecad
def test_command_without_trimesh(mesh_files, tmp_path):
    """The example (BRep) and binary STL / PLY: exit 0; ASCII STL: exit 2 and one line that
    names trimesh and how to install it, no traceback."""
    r = command("example", "--out", str(tmp_path / "ex"), cwd=str(tmp_path))
    assert r.returncode == 0, r.stderr[-2000:]
    for name in ("grid.stl", "grid.ply"):
        r = command("analyze", str(mesh_files / name), "--lref", "2", "--json")
        assert r.returncode == 0, r.stderr[-2000:]
        assert '"representation": "mesh"' in r.stdout and "Traceback" not in r.stderr
    r = command("analyze", str(mesh_files / "grid_ascii.stl"), "--lref", "2")
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("hullprod: error:")]
    assert len(errors) == 1, r.stderr
    assert "ASCII STL" in errors[0] and "trimesh" in errors[0] and "pip install" in errors[0], errors[0]


@needs_freecad
@pytest.mark.skipif(shutil.which("freecadcmd") is None, reason="freecadcmd is not installed")
def test_freecadcmd_self_test_without_trimesh(tmp_path):
    """FreeCAD's console loads the workbench (Init.py) and the installed self-test passes."""
    home = home_with_this_checkout(tmp_path / "home")
    script = BLOCK + textwrap.dedent("""
        import unittest
        import FreeCAD
        assert "TestHullProd" in FreeCAD.__unit_test__, FreeCAD.__unit_test__
        import TestHullProd
        suite = unittest.defaultTestLoader.loadTestsFromModule(TestHullProd)
        result = unittest.TextTestRunner(stream=sys.stdout, verbosity=1).run(suite)
        print("self-test without trimesh: %d run, %d failed" % (result.testsRun,
              len(result.failures) + len(result.errors)), flush=True)
        sys.exit(0 if result.wasSuccessful() else 1)
    """)
    env = fresh_user_env(home)
    (tmp_path / "self_test.py").write_text(script)
    r = subprocess.run(["freecadcmd", str(tmp_path / "self_test.py")], capture_output=True, text=True, env=env,
                       cwd=str(tmp_path), timeout=300)
    out = r.stdout + r.stderr
    assert r.returncode == 0 and re.search(r"without trimesh: (1[0-9]|[2-9][0-9]) run, 0 failed", out), out[-3000:]
