"""The runtime settings (core.runtime) reach every process HullProd starts: the ./hullprod
launcher's command, the GUI's assessment process, batch workers and fresh reading
interpreters, with the caller's own values kept."""
import json
import os
import subprocess
import sys

from conftest import ROOT
from hullprod_wb.core import runtime

NAMES = [s.name for s in runtime.SETTINGS]
PRINT_ENV = "import json, os; print(json.dumps(dict(os.environ)))"


def _launcher_env(**given):
    """Environment the launcher hands to Python: the launcher's last line is replaced by a
    print of the environment (the rest of the script runs as it is)."""
    script = open(os.path.join(ROOT, "hullprod")).read()
    body, _, last = script.rstrip("\n").rpartition("\n")
    assert "exec /usr/bin/python3 -P -m hullprod_wb.cli" in last
    env = {k: v for k, v in os.environ.items() if k not in NAMES}
    env.update(given)
    out = subprocess.run(["sh", "-c", body + "\nenv\n", os.path.join(ROOT, "hullprod")],
                         capture_output=True, text=True, env=env, check=True).stdout
    return dict(line.split("=", 1) for line in out.splitlines() if "=" in line)


def _child_env(env):
    """The environment a Python process started with env sees."""
    out = subprocess.run([sys.executable, "-c", PRINT_ENV], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def test_the_launcher_exports_the_table():
    script = open(os.path.join(ROOT, "hullprod")).read()
    assert "\n".join(runtime.shell_exports()) in script


def test_the_launchers_command_starts_with_every_setting():
    env = _launcher_env()
    assert {k: env.get(k) for k in NAMES} == {s.name: s.value for s in runtime.SETTINGS}


def test_launcher_keeps_the_callers_values():
    env = _launcher_env(MALLOC_TOP_PAD_="4096", OPENBLAS_NUM_THREADS="2")
    assert env["MALLOC_TOP_PAD_"] == "4096"
    assert env["OPENBLAS_NUM_THREADS"] == "2"
    assert env["MALLOC_TRIM_THRESHOLD_"] == "1099511627776"


def test_the_guis_assessment_process_starts_with_the_settings():
    from hullprod_wb.app.assessment_process import PACKAGE_ROOT, worker_environment
    base = {k: v for k, v in os.environ.items() if k not in NAMES}
    base.update(MALLOC_TOP_PAD_="4096", PYTHONHOME="/nowhere")
    seen = _child_env(worker_environment(base))
    assert seen["MALLOC_TOP_PAD_"] == "4096" and "PYTHONHOME" not in seen
    assert all(seen[s.name] == s.value for s in runtime.SETTINGS if s.name != "MALLOC_TOP_PAD_")
    assert seen["PYTHONPATH"].split(os.pathsep)[0] == PACKAGE_ROOT


def test_batch_workers_start_with_the_settings_and_one_thread():
    from hullprod_wb.batch.runner import worker_environ
    before = dict(os.environ)
    os.environ["OPENBLAS_NUM_THREADS"] = "4"
    try:
        with worker_environ():
            seen = _child_env(dict(os.environ))
        assert os.environ["OPENBLAS_NUM_THREADS"] == "4"  # restored
    finally:
        os.environ.clear()
        os.environ.update(before)
    assert seen["OPENBLAS_NUM_THREADS"] == seen["MKL_NUM_THREADS"] == seen["HULLPROD_JOBS"] == "1"
    assert all(seen[s.name] == os.environ.get(s.name, s.value) for s in runtime.SETTINGS
               if s.name not in runtime.BATCH_WORKER)


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
