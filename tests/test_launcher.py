"""The ./hullprod launcher: environment it sets for the command, callers' values kept."""
import os
import subprocess

from conftest import ROOT

DEFAULTS = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
            "MALLOC_MMAP_THRESHOLD_": "33554432", "MALLOC_TRIM_THRESHOLD_": "1099511627776",
            "MALLOC_TOP_PAD_": "67108864", "MALLOC_ARENA_MAX": "1",
            "MALLOC_MMAP_MAX_": "0", "NUMPY_MADVISE_HUGEPAGE": "0"}


def _launcher_env(**given):
    """Environment the launcher hands to Python: the launcher's last line is replaced by a
    print of the environment (the rest of the script runs as it is)."""
    script = open(os.path.join(ROOT, "hullprod")).read()
    body, _, last = script.rstrip("\n").rpartition("\n")
    assert "exec /usr/bin/python3 -P -m hullprod_wb.cli" in last
    env = {k: v for k, v in os.environ.items() if k not in DEFAULTS}
    env.update(given)
    out = subprocess.run(["sh", "-c", body + "\nenv\n", os.path.join(ROOT, "hullprod")],
                         capture_output=True, text=True, env=env, check=True).stdout
    return dict(line.split("=", 1) for line in out.splitlines() if "=" in line)


def test_launcher_sets_thread_and_heap_defaults():
    env = _launcher_env()
    for key, value in DEFAULTS.items():
        assert env.get(key) == value, key


def test_the_guis_assessment_process_runs_with_the_launchers_environment():
    from hullprod_wb.app.assessment_process import CLI_ENV
    assert CLI_ENV == DEFAULTS


def test_launcher_keeps_the_callers_values():
    env = _launcher_env(MALLOC_TOP_PAD_="4096", OPENBLAS_NUM_THREADS="2")
    assert env["MALLOC_TOP_PAD_"] == "4096"
    assert env["OPENBLAS_NUM_THREADS"] == "2"
    assert env["MALLOC_TRIM_THRESHOLD_"] == DEFAULTS["MALLOC_TRIM_THRESHOLD_"]


def test_launcher_uses_its_own_package_whatever_the_current_directory(tmp_path):
    """A hullprod_wb package in the current directory (another checkout, say) is not the
    one the launcher runs."""
    fake = tmp_path / "hullprod_wb"
    fake.mkdir()
    (fake / "__init__.py").write_text("")
    (fake / "cli.py").write_text("print('the package of the current directory')\n")
    out = subprocess.run([os.path.join(ROOT, "hullprod"), "--help"], capture_output=True,
                         text=True, cwd=str(tmp_path))
    assert out.returncode == 0, out.stderr
    assert "current directory" not in out.stdout
    assert "analyze" in out.stdout
