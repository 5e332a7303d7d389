"""The module split of issue 11: names stay importable where they were, the CLI stays light."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# old module -> (new module, names defined there now and re-exported by the old one)
MOVED = {
    "splicer.align.dtw": ("splicer.align.kernels", ["_dp_rows", "_dp_fused", "_backtrack"]),
    "splicer.rig.repair": ("splicer.rig.dropouts", ["detect_problems", "hand_joints", "MAX_FINGER_SPEED_DEG_S",
                                                    "FROZEN_MIN_S", "FROZEN_MIN_FRAMES", "FROZEN_EXIT_RATIO",
                                                    "SPIKE_MAX_FRAMES", "KINDS"]),
    "splicer.batch": ("splicer.batch_summary", ["write_summary", "summary_row"]),
    "splicer.evaluation.scenarios": ("splicer.evaluation.scenario_types",
                                     ["Scenario", "COMPONENTS", "SCENARIOS", "scenario", "ScenarioSeparation",
                                      "invert_time", "hands_take_time", "alignment_error_s"]),
    "splicer.evaluation.scenario_eval": ("splicer.evaluation.scenario_scores",
                                         ["SCENARIO_METRICS", "ranges_mask", "report_flags", "flag_scores",
                                          "uncovered_scores", "alignment_scores", "pause_scores", "confidence_auc",
                                          "judged_error"]),
    "splicer.evaluation.evaluate": ("splicer.evaluation.accuracy",
                                    ["METHODS", "METRICS", "summarize", "to_markdown", "compact_markdown", "checks",
                                     "_alignment_scores"]),
    "splicer.evaluation.separate": ("splicer.evaluation.handforms",
                                    ["wrist_rooted", "forearm_rooted", "hand_only_files", "mirror_motion"]),
}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_moved_names_are_the_same_objects_in_the_old_module(old):
    new, names = MOVED[old]
    a, b = importlib.import_module(old), importlib.import_module(new)
    for name in names:
        assert getattr(a, name) is getattr(b, name), f"{old}.{name} is not {new}.{name}"


@pytest.mark.parametrize("old", sorted(MOVED))
def test_every_public_name_of_the_old_module_still_resolves(old):
    mod = importlib.import_module(old)
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert missing == []


def test_batch_folders_mode_is_reexported():
    from splicer import batch, batch_folders

    assert batch.pair_folders is batch_folders.pair_folders


def test_cli_import_loads_no_evaluation_pandas_or_matplotlib():
    code = ("import sys, splicer.cli; print('\\n'.join(m for m in sys.modules if m.split('.')[0] in "
            "('pandas', 'matplotlib') or m.startswith('splicer.evaluation')))")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=ROOT, check=True)
    assert out.stdout.split() == []


def _module_imports(root: Path) -> dict[str, set[str]]:
    """Module -> the package's modules it imports at module level (not inside functions, not
    under ``if TYPE_CHECKING``): the imports that run when it is imported."""
    import ast

    mods = {}
    for p in (root / "splicer").rglob("*.py"):
        parts = list(p.relative_to(root).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        mods[".".join(parts[:-1] if is_pkg else parts)] = (p, is_pkg)
    graph = {}
    for name, (p, is_pkg) in mods.items():
        pkg = name if is_pkg else name.rsplit(".", 1)[0]
        deps = set()
        for node in ast.parse(p.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                continue
            if isinstance(node, (ast.Try, ast.If)):
                found = [n for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom))]
            else:
                found = [node] if isinstance(node, (ast.Import, ast.ImportFrom)) else []
            for n in found:
                if isinstance(n, ast.Import):
                    deps.update(a.name for a in n.names if a.name in mods)
                    continue
                base = n.module or ""
                if n.level:
                    up = pkg.split(".")[:len(pkg.split(".")) - (n.level - 1)]
                    base = ".".join(up + ([n.module] if n.module else []))
                for a in n.names:
                    deps.add(f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base)
        graph[name] = {d for d in deps if d in mods and d != name}
    return graph


def test_no_import_cycles_in_the_package():
    graph = _module_imports(ROOT)
    assert "splicer.align.kernels" in graph["splicer.align.dtw"]  # the walk sees relative imports
    assert "splicer.evaluation.scenario_types" in graph["splicer.evaluation.scenario_edits"]
    cycles = []
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(v, path):
        state[v] = 1
        for w in sorted(graph[v]):
            if state.get(w) == 1:
                cycles.append(path[path.index(w):] + [w])
            elif w not in state:
                visit(w, path + [w])
        state[v] = 2

    for v in sorted(graph):
        if v not in state:
            visit(v, [v])
    assert cycles == []
