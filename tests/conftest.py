"""Shared fixtures: the seeded ``rng`` and the real captures in ``../shared/motions``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

#: Real motion-capture files, next to the repository (never copied into it).
SHARED_MOTIONS = Path(__file__).resolve().parents[1].parent / "shared" / "motions"
SHARED_SKIP_REASON = "../shared/motions not found: real-capture tests need the shared data folder"
DATA = Path(__file__).resolve().parent / "data"


def shared_bvh_files() -> list[Path]:
    """All ``.bvh`` files under ``../shared/motions`` (empty when the folder is absent)."""
    if not SHARED_MOTIONS.is_dir():
        return []
    return sorted(SHARED_MOTIONS.rglob("*.bvh"))


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture
def shared_motions() -> Path:
    """The ``../shared/motions`` folder; skips the test when it is absent."""
    if not SHARED_MOTIONS.is_dir():
        pytest.skip(SHARED_SKIP_REASON)
    return SHARED_MOTIONS


def pytest_generate_tests(metafunc):
    """Parametrise a ``shared_bvh`` argument with every real ``.bvh`` file (or one skip)."""
    if "shared_bvh" in metafunc.fixturenames:
        files = shared_bvh_files()
        if files:
            params = [pytest.param(p, id=str(p.relative_to(SHARED_MOTIONS))) for p in files]
        else:
            params = [pytest.param(None, id="no-shared-motions", marks=pytest.mark.skip(reason=SHARED_SKIP_REASON))]
        metafunc.parametrize("shared_bvh", params)
