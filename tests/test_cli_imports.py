"""What the ``splice`` command imports (issue 12): ``--help`` and ``--version`` nothing numeric, and a
run without ``--plot`` no plotting library, and one with it Pillow but not matplotlib.  Modules, not seconds: the times are benchmarks/bench_startup.py's."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MOTIONS = ROOT / "motions"

# runs splicer.cli's main with the given arguments, then prints the top-level modules it imported
_WRAPPER = """
import json, sys
from splicer.cli import main
try:
    code = main(sys.argv[1:])
except SystemExit as e:
    code = e.code
print(json.dumps({"code": code, "modules": sorted({m.split('.')[0] for m in sys.modules})}))
"""


def _modules(*args: str, cwd: Path) -> tuple[int, set[str]]:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", _WRAPPER, *args], capture_output=True, text=True, env=env,
                         cwd=cwd, check=True).stdout
    last = json.loads(out.strip().splitlines()[-1])
    return last["code"], set(last["modules"])


HEAVY = {"numpy", "numba", "llvmlite", "scipy", "pandas", "matplotlib", "bvhio", "yaml", "dask", "bpy"}


@pytest.mark.parametrize("flag", ["--help", "--version"])
def test_help_and_version_import_nothing_numeric(flag, tmp_path):
    code, mods = _modules(flag, cwd=tmp_path)
    assert code == 0
    assert not mods & HEAVY, sorted(mods & HEAVY)


@pytest.mark.slow
def test_a_run_without_plot_imports_no_plotting_no_dataframes_no_scipy(tmp_path):
    # scipy: numba imports it unless the command starts numba without it (cli._start_numba_without_scipy);
    # the sample has no gaps to fill, the only use of scipy on this path
    code, mods = _modules(str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"), "-o", "out.bvh",
                          "--constraints", str(MOTIONS / "sample_sync.yaml"), "--report", "r.json", "-q",
                          cwd=tmp_path)
    assert code == 0 and (tmp_path / "out.bvh").exists()
    unwanted = {"matplotlib", "PIL", "pandas", "scipy", "dask", "distributed", "bpy"}
    assert not mods & unwanted, sorted(mods & unwanted)
    assert "numba" in mods  # the kernels ran: the check above is not vacuous


def test_numba_started_without_scipy_leaves_scipy_importable(tmp_path):
    # gap filling imports scipy.interpolate after the command has started numba without scipy
    code = ("import sys; from splicer.cli import _start_numba_without_scipy; _start_numba_without_scipy(); "
            "assert 'numba' in sys.modules and 'scipy' not in sys.modules; "
            "from scipy.interpolate import CubicSpline; print(float(CubicSpline([0, 1, 2], [0, 1, 0])(0.5)))")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path, check=True)
    assert out.stdout.strip() == "0.75"


@pytest.mark.slow
def test_a_run_with_plot_draws_with_pillow_not_matplotlib(tmp_path):
    code, mods = _modules(str(MOTIONS / "sample_body.bvh"), str(MOTIONS / "sample_hands.bvh"), "-o", "out.bvh",
                          "--plot", "p.png", "-q", cwd=tmp_path)
    assert code == 0 and (tmp_path / "p.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "PIL" in mods and "matplotlib" not in mods


def test_the_scripts_question_to_a_server_imports_nothing_numeric(tmp_path):
    """The `splice` script first asks a running splice-server to take the run (none runs here)."""
    code = ("import json, sys\nfrom splicer.server_client import delegate\nr = delegate(['a.bvh', 'b.bvh', '-o', 'o.bvh'])\n"
            "print(json.dumps({'r': r, 'modules': sorted({m.split('.')[0] for m in sys.modules})}))")
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
               SPLICER_SERVER_SOCKET=str(tmp_path / "none.sock"))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path, check=True)
    last = json.loads(out.stdout.strip().splitlines()[-1])
    assert last["r"] is None  # no server: the script runs the command itself
    assert not set(last["modules"]) & HEAVY, sorted(set(last["modules"]) & HEAVY)
