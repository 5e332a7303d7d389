"""Every code block of README.md, extracted from the README itself and run.

* ```python blocks run in a temporary folder holding the bundled sample under the names the
  README uses (body.bvh, hands.bvh, right_hand.bvh, sync.yaml).
* ```sh blocks: each ``splice`` command runs as ``python -m splicer.cli`` in such a folder and
  must exit 0 and write what it names; ``splice-server`` commands run as ``python -m
  splicer.server`` on a socket of the block's own (a server a block starts is stopped after it).  Lines that set up an environment (``python3 -m venv``,
  ``pip install``) are skipped: the tests already run inside one.  The line that runs the test
  suite is skipped (it would run this test again), and so are ``splicer-evaluate`` (minutes on
  the real capture in ../shared; benchmarks/ holds its output) and ``mutmut`` (tens of minutes;
  tests/mutation_survivors.md holds its result).
* ```yaml blocks are constraints files: they must parse (:func:`splicer.io.config.parse_config`).

A block in another language (the JSON report sketch with ``...``, the diagram) is not code.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from splicer.io.config import parse_config

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MOTIONS = ROOT / "motions"

_BLOCK = re.compile(r"^```(\w*)[ \t]*\n(.*?)^```[ \t]*$", re.S | re.M)


def readme_blocks() -> list[tuple[str, int, str]]:
    """(language, line of the opening fence, code) of every fenced block of README.md."""
    text = README.read_text(encoding="utf-8")
    return [(m.group(1), text.count("\n", 0, m.start()) + 1, m.group(2)) for m in _BLOCK.finditer(text)]


def _params(lang: str):
    return [pytest.param(code, id=f"line{line}") for lg, line, code in readme_blocks() if lg == lang]


def test_the_readme_has_the_blocks_these_tests_expect():
    langs = [lg for lg, _, _ in readme_blocks()]
    assert langs.count("python") >= 1 and langs.count("sh") >= 3 and langs.count("yaml") >= 2


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    """A folder with the sample under the README's file names, as the current directory."""
    shutil.copy(MOTIONS / "sample_body.bvh", tmp_path / "body.bvh")
    shutil.copy(MOTIONS / "sample_hands.bvh", tmp_path / "hands.bvh")
    shutil.copy(MOTIONS / "sample_hands.bvh", tmp_path / "right_hand.bvh")
    shutil.copy(MOTIONS / "sample_sync.yaml", tmp_path / "sync.yaml")
    (tmp_path / "motions").symlink_to(MOTIONS, target_is_directory=True)
    for name, code in _named_files().items():  # files the README shows whole (the batch manifest)
        (tmp_path / name).write_text(code, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _named_files() -> dict[str, str]:
    """YAML blocks whose first line names a file other than the constraints file
    (``# day1.yaml: ...``), by that name."""
    out = {}
    for lg, _, code in readme_blocks():
        m = re.match(r"#\s*([\w.-]+\.ya?ml)\b", code)
        if lg == "yaml" and m and m.group(1) != "sync.yaml":
            out[m.group(1)] = code
    return out


# -- python ----------------------------------------------------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize("code", _params("python"))
def test_python_block(code, workdir):
    namespace: dict = {"__name__": "__readme__"}
    exec(compile(code, str(README), "exec"), namespace)
    for name in re.findall(r"""["']([\w.-]+\.(?:bvh|png|json))["']""", code):
        assert (workdir / name).exists(), f"the README's Python block should have written {name}"


# -- sh --------------------------------------------------------------------------------------

_SKIPPED = {
    "venv": "sets up a virtual environment: the tests already run in one",
    "pip": "installs the package: the tests already run against this checkout",
    "pytest": "runs the test suite, which would run this test again",
    "splicer-evaluate": "the evaluation on ../shared's real capture takes minutes; benchmarks/ holds its output",
    "benchmark": "a benchmark takes minutes; benchmarks/ holds its output",
    "mutmut": "mutation testing runs for tens of minutes; tests/mutation_survivors.md holds its result",
}


def _commands(block: str) -> list[tuple[str, list[str] | None]]:
    """Each command of a sh block, with its argv (``splice`` -> ``python -m splicer.cli``) or
    None and the reason it is skipped."""
    out = []
    for line in block.splitlines():
        line = re.sub(r"\s+#.*$", "", line).strip()
        for cmd in filter(None, (c.strip() for c in line.split("&&"))):
            argv = shlex.split(cmd)
            prog = os.path.basename(argv[0])
            if prog.startswith("python") and argv[1:3] == ["-m", "venv"]:
                out.append((cmd, _SKIPPED["venv"]))
            elif "pip" in prog:
                out.append((cmd, _SKIPPED["pip"]))
            elif prog.startswith("python") and "pytest" in argv:
                out.append((cmd, _SKIPPED["pytest"]))
            elif prog in ("splicer-evaluate", "mutmut"):
                out.append((cmd, _SKIPPED[prog]))
            elif prog.startswith("python") and len(argv) > 1 and argv[1].startswith("benchmarks/"):
                out.append((cmd, _SKIPPED["benchmark"]))
            elif prog == "splice":
                out.append((cmd, [sys.executable, "-m", "splicer.cli", *argv[1:]]))
            elif prog == "splice-server":
                out.append((cmd, [sys.executable, "-m", "splicer.server", *argv[1:]]))
            elif prog == "splice-batch":
                out.append((cmd, [sys.executable, "-m", "splicer.batch", *argv[1:], "--workers", "1", "-q"]))
            else:
                raise AssertionError(f"README command this test does not know how to run: {cmd!r}")
    return out


def test_sh_commands_are_all_known():
    kinds = [c for lg, _, code in readme_blocks() if lg == "sh" for c in _commands(code)]
    runnable = [argv for _, argv in kinds if isinstance(argv, list)]
    assert len(runnable) >= 5  # the quick start and the four of 'Using it'


@pytest.mark.slow
@pytest.mark.parametrize("code", _params("sh"))
def test_sh_block(code, workdir):
    import tempfile

    ran = 0
    reasons = []
    sock_dir = tempfile.mkdtemp(prefix="spl-")  # a block that starts splice-server starts its own, here
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
           "PYTHONWARNINGS": "", "SPLICER_SERVER_SOCKET": os.path.join(sock_dir, "s.sock")}
    try:
        ran, reasons = _run_sh_block(code, workdir, env)
    finally:
        subprocess.run([sys.executable, "-m", "splicer.server", "stop", "-q"], env=env, capture_output=True)
        shutil.rmtree(sock_dir, ignore_errors=True)
    if not ran:
        pytest.skip("; ".join(reasons))


def _run_sh_block(code, workdir, env) -> tuple[int, list[str]]:
    ran = 0
    reasons = []
    for cmd, argv in _commands(code):
        if not isinstance(argv, list):
            reasons.append(f"{cmd!r}: {argv}")
            continue
        p = subprocess.run(argv, cwd=workdir, capture_output=True, text=True, env=env)
        assert p.returncode == 0, f"{cmd}\n{p.stderr}"
        assert "Traceback" not in p.stderr
        if argv[2] == "splicer.server":
            ran += 1
            continue
        i = argv.index("-o")
        if argv[2] == "splicer.batch":  # the summary in -o, each pair's output where its manifest entry says
            import yaml

            out = workdir / argv[i + 1]
            assert (out / "summary.md").stat().st_size > 0, cmd
            manifest = yaml.safe_load((workdir / argv[3]).read_text())
            for pair in manifest["pairs"]:
                assert (workdir / pair["output"]).stat().st_size > 0, (cmd, pair["output"])
            shutil.rmtree(out)
            ran += 1
            continue
        written = [argv[i + 1]] + [argv[k + 1] for k, a in enumerate(argv) if a in ("--report", "--plot")]
        for name in written:
            assert (workdir / name).stat().st_size > 0, f"{cmd}: {name} not written"
            (workdir / name).unlink()
        ran += 1
    return ran, reasons


# -- yaml ------------------------------------------------------------------------------------

@pytest.mark.parametrize("code", [c for c in _params("yaml") if not re.match(r"#\s*day1\.yaml", c.values[0])])
def test_yaml_block_is_a_valid_constraints_file(code):
    cfg = parse_config(code, "README.md")
    assert cfg.pairs or cfg.joints  # each block shows pairs or a joint mapping
    for p in cfg.pairs:
        assert p.side in ("left", "right", "both")
