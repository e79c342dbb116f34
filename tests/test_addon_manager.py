"""HullProd as FreeCAD's Addon Manager handles it: its own installer (AddonInstaller, run in
freecadcmd by tests/addon_manager_install.py) installs a local clone into a fresh user's Mod
folder, the installed copy passes `freecadcmd -t TestHullProd`, and its own metadata parser
reads package.xml without a warning, as does FreeCAD's own reader (FreeCAD.Metadata). Skipped
where freecadcmd or those modules are missing (FreeCAD 0.20 has neither addonmanager_installer
nor addonmanager_metadata: its Addon Manager reads package.xml with FreeCAD.Metadata)."""
import json
import os
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET

import pytest

from conftest import ROOT, fresh_user_env

FREECADCMD = shutil.which("freecadcmd")
HELPER = os.path.join(ROOT, "tests", "addon_manager_install.py")
NS = {"p": "https://wiki.freecad.org/Package_Metadata"}
#: Any connection the Addon Manager tries goes to a closed local port and fails at once.
NO_NETWORK = "http://127.0.0.1:9"

pytestmark = pytest.mark.skipif(FREECADCMD is None, reason="freecadcmd is not installed")


def fresh_env(home):
    """The environment of a user who has never started FreeCAD, with home as HOME, no network."""
    env = {k: v for k, v in fresh_user_env(home).items() if "proxy" not in k.lower()}
    env.update(http_proxy=NO_NETWORK, https_proxy=NO_NETWORK, HTTP_PROXY=NO_NETWORK,
               HTTPS_PROXY=NO_NETWORK, ALL_PROXY=NO_NETWORK)
    return env


def freecadcmd(env, *args, cwd):
    return subprocess.run([FREECADCMD] + list(args), capture_output=True, text=True, env=env,
                          cwd=str(cwd), timeout=300)


def addon_manager(env, task, source, cwd):
    """tests/addon_manager_install.py's task in freecadcmd: (its JSON result, the process).
    Skips where the Addon Manager's modules cannot be imported."""
    out = os.path.join(str(cwd), "am-%s.json" % task)
    p = freecadcmd(dict(env, HULLPROD_AM_TASK=task, HULLPROD_AM_SOURCE=str(source), HULLPROD_AM_RESULT=out),
                   HELPER, cwd=cwd)
    assert os.path.isfile(out), "no result from freecadcmd:\n" + p.stdout[-3000:] + p.stderr[-3000:]
    with open(out, encoding="utf-8") as f:
        result = json.load(f)
    if "import_error" in result:
        pytest.skip("FreeCAD %s: the Addon Manager's modules are not importable in freecadcmd (%s)"
                    % (".".join(result["freecad"]), result["import_error"]))
    assert "exception" not in result, result["exception"]
    return result, p


#: What a clone's folder holds that git does not track (the walk where git is not installed).
UNTRACKED_DIRS = {".git", "__pycache__", ".pytest_cache"}


def working_tree_files():
    """The working tree's files that a commit of it would hold: git's tracked and untracked,
    not ignored files; where git is missing (the chroots), every file but caches and .git."""
    # .git is a folder in a clone and a file (a pointer to the repository) in a git worktree
    if shutil.which("git") and os.path.exists(os.path.join(ROOT, ".git")):
        p = subprocess.run(["git", "-C", ROOT, "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                           capture_output=True)
        if p.returncode == 0:  # not, say, where git refuses a checkout another user owns
            return sorted(n for n in set(p.stdout.decode().split("\0"))
                          if n and os.path.lexists(os.path.join(ROOT, n)))
    names = []
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in UNTRACKED_DIRS]
        rel = os.path.relpath(folder, ROOT)
        names += [os.path.normpath(os.path.join(rel, n)) for n in files
                  if not n.endswith(".pyc") and n not in UNTRACKED_DIRS]
    return sorted(names)


def make_clone(dest):
    """dest: the working tree's files (so uncommitted changes are tested too), made a git
    repository with one commit on branch main where git is installed."""
    names = working_tree_files()
    for name in names:
        os.makedirs(os.path.dirname(os.path.join(dest, name)), exist_ok=True)
        shutil.copy2(os.path.join(ROOT, name), os.path.join(dest, name), follow_symlinks=False)
    if shutil.which("git"):
        env = {k: v for k, v in os.environ.items() if not k.startswith("GIT_")}
        git = ["git", "-c", "user.name=HullProd test", "-c", "user.email=test@example.invalid",
               "-c", "commit.gpgsign=false", "-C", str(dest)]
        for args in (["init", "-q", "-b", "main"], ["add", "-A"], ["commit", "-q", "-m", "working tree"]):
            subprocess.run(git + args, check=True, env=env, capture_output=True)
    return names


def files_under(folder):
    """Relative paths of the files under folder, .git excluded."""
    found = set()
    for here, dirs, files in os.walk(folder):
        dirs[:] = [d for d in dirs if d != ".git"]
        found.update(os.path.relpath(os.path.join(here, n), folder) for n in files)
    return found


def package_xml():
    """package.xml's name, version, python dependencies and workbench (name, classname)."""
    root = ET.parse(os.path.join(ROOT, "package.xml")).getroot()
    wb = root.find("p:content/p:workbench", NS)
    return {"name": root.findtext("p:name", namespaces=NS), "version": root.findtext("p:version", namespaces=NS),
            "python": sorted(d.text for d in root.findall("p:depend", NS) if d.get("type") == "python"),
            "workbench": (wb.findtext("p:name", namespaces=NS), wb.findtext("p:classname", namespaces=NS)),
            "freecadmin": root.findtext("p:freecadmin", namespaces=NS)}


def version_list(text):
    return [int(x) for x in text.split(".")] + [""]


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """HullProd installed by the Addon Manager from a local clone into a fresh user's folders:
    (env, elsewhere folder, helper result, clone's files, installed files)."""
    home = tmp_path_factory.mktemp("fresh_user")
    work = tmp_path_factory.mktemp("elsewhere")
    clone = tmp_path_factory.mktemp("clone") / "HullProd"
    clone.mkdir()
    names = make_clone(clone)
    env = fresh_env(home)
    result, p = addon_manager(env, "install", clone, work)
    result["stderr"] = p.stderr
    target = result["installation_path"]
    return env, work, result, set(names), files_under(target) if os.path.isdir(target) else set()


def test_addon_manager_installs_into_the_users_mod_folder(installed):
    """AddonInstaller.run() succeeds and copies the clone to <user app data>/Mod/HullProd."""
    env, work, r, cloned, got = installed
    assert r["returned"] is True and "success" in r["signals"], r
    assert not [s for s in r["signals"] if s.startswith("failure")], r["signals"]
    mod = os.path.join(r["user_app_data"], "Mod", "HullProd")
    assert os.path.realpath(r["installation_path"]) == os.path.realpath(mod)
    assert os.path.realpath(mod).startswith(os.path.realpath(env["HOME"]) + os.sep)
    assert os.path.isdir(mod) and not os.path.islink(mod)
    assert {"package.xml", "Init.py", "InitGui.py", "TestHullProd.py", "hullprod_wb/__init__.py"} <= got
    assert got == cloned, ("not installed", sorted(cloned - got)[:10], "unexpected", sorted(got - cloned)[:10])
    with open(os.path.join(mod, "package.xml"), "rb") as a, open(os.path.join(ROOT, "package.xml"), "rb") as b:
        assert a.read() == b.read()
    meta = package_xml()
    assert r["installed_version"] == version_list(meta["version"])
    assert r["workbench"] == meta["workbench"][1]
    assert r["status"] == "PENDING_RESTART"
    assert r["python_requires"] == meta["python"]
    # What is not importable here the Addon Manager would offer to install: on its allow-list.
    assert set(r["python_missing"]) <= set(r["python_allowed"]), r["python_missing"]
    assert r["stderr"].strip() == "", r["stderr"]


def test_installed_copy_passes_freecads_self_test(installed):
    """freecadcmd -t TestHullProd in the fresh user's HOME runs the installed copy: exit 0, OK, >= 10 tests."""
    env, work, r, _, _ = installed
    mod = os.path.realpath(r["installation_path"])
    p = freecadcmd(env, "-c", "import FreeCAD, hullprod_wb, TestHullProd\n"
                   "print('USERDIR=' + FreeCAD.getUserAppDataDir())\n"
                   "print('PKG=' + hullprod_wb.__file__)\nprint('TEST=' + TestHullProd.__file__)\n"
                   "print('UNIT=' + ' '.join(FreeCAD.__unit_test__))", cwd=work)
    out = p.stdout + p.stderr
    found = dict(re.findall(r"^(USERDIR|PKG|TEST|UNIT)=(.*)$", p.stdout, re.M))
    assert set(found) == {"USERDIR", "PKG", "TEST", "UNIT"}, out[-3000:]
    assert os.path.realpath(os.path.join(found["USERDIR"], "Mod", "HullProd")) == mod
    for key in ("PKG", "TEST"):
        assert os.path.realpath(found[key]).startswith(mod + os.sep), (key, found[key], mod)
    assert "TestHullProd" in found["UNIT"].split()
    p = freecadcmd(env, "-t", "TestHullProd", cwd=work)
    out = p.stdout + p.stderr
    ran = re.findall(r"^Ran (\d+) tests? in ([\d.]+)s", out, re.M)
    assert p.returncode == 0 and ran and re.search(r"^OK", out, re.M), out[-4000:]
    assert int(ran[-1][0]) >= 10, ran


def test_addon_managers_parser_reads_package_xml(tmp_path):
    """MetadataReader.from_file and Addon.load_metadata_file: nothing printed, fields as written."""
    home = tmp_path / "home"
    home.mkdir()
    r, p = addon_manager(fresh_env(home), "metadata", os.path.join(ROOT, "package.xml"), tmp_path)
    assert r["printed"] == "", r["printed"]
    assert p.stderr.strip() == "", p.stderr
    meta = package_xml()
    assert r["name"] == meta["name"] == "HullProd"
    assert r["version"] == version_list(meta["version"])
    assert r["freecadmin"] == version_list(meta["freecadmin"])
    assert r["licenses"] == ["MIT"]
    assert [b for _, b in r["repository"]] == ["main"]
    assert r["python_depends"] == meta["python"]
    assert [(wb["name"], wb["classname"]) for wb in r["workbenches"]] == [meta["workbench"]]
    assert meta["workbench"][1] == "HullProdWorkbench"
    assert r["workbenches"][0]["subdirectory"] == "./"
    assert r["version_ok_here"] is True
    assert r["addon_workbench"] == "HullProdWorkbench"
    assert r["addon_python_requires"] == meta["python"]


def test_freecads_own_reader_reads_package_xml(tmp_path):
    """FreeCAD.Metadata, which FreeCAD's start-up and the 0.20 Addon Manager read package.xml
    with: nothing on stderr, fields as written, this FreeCAD supported."""
    home = tmp_path / "home"
    home.mkdir()
    r, p = addon_manager(fresh_env(home), "freecad-metadata", os.path.join(ROOT, "package.xml"), tmp_path)
    assert p.stderr.strip() == "", p.stderr
    meta = package_xml()
    assert (r["name"], r["version"], r["freecadmin"]) == (meta["name"], meta["version"], meta["freecadmin"])
    assert r["licenses"] == ["MIT"]
    assert r["depends"] == meta["python"]
    assert [(wb["name"], wb["classname"], wb["subdirectory"]) for wb in r["workbenches"]] == [
        meta["workbench"] + ("./",)]
    assert r["supports_here"] is True
