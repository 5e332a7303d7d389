"""Stage 1, load: both takes, the constraints file and optional optical markers."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path


from ..errors import SplicerWarning
from ..align.frames import FrameSpaces
from ..model.motion import Motion
from .log import Log

__all__ = ['Inputs', 'load_inputs']


# ---------------------------------------------------------------- stage 1: load

@dataclass(frozen=True, eq=False)
class Inputs:
    """Both takes and the constraints/config file."""

    body: Motion
    hands: Motion
    config: object  # SpliceConfig
    # --- issue 14: optical markers (Trajectories) sharing each take's timeline, or None ---
    body_markers: object = None
    hands_markers: object = None

    @property
    def spaces(self) -> FrameSpaces:
        return FrameSpaces(self.body.n_frames, self.hands.n_frames, self.body.fps, self.hands.fps)


def _file_size(path) -> int:
    try:
        return os.path.getsize(path)
    except (OSError, TypeError, ValueError):
        return 0  # the reader says what is wrong with it


def load_inputs(body, hands, config=None, log: Log | None = None, *, body_markers=None,
                hands_markers=None) -> Inputs:
    """Read both takes (paths or :class:`~splicer.model.Motion`) and the config (path or SpliceConfig).

    ``body_markers``, ``hands_markers``: optional marker files (C3D, TRC, CSV; paths or
    :class:`~splicer.trajectories.Trajectories`) captured with each take, used for the alignment."""
    from ..io.config import SpliceConfig, read_config
    from ..io.motion_io import read_motion  # BVH or FBX by suffix

    log = log or Log()
    log.progress("read", 0.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", SplicerWarning)
        sizes = [0 if isinstance(x, Motion) else _file_size(x) for x in (body, hands)]
        total = sum(sizes) or 1
        # the bar by bytes: the body read and parsed, then the hands
        bm = body if isinstance(body, Motion) else read_motion(
            body, progress=lambda f: log.progress("read", f * sizes[0] / total))
        hm = hands if isinstance(hands, Motion) else read_motion(
            hands, progress=lambda f: log.progress("read", (sizes[0] + f * sizes[1]) / total))
    for w in caught:
        if issubclass(w.category, SplicerWarning):
            log.note(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    cfg = read_config(config) if isinstance(config, (str, Path)) else (config or SpliceConfig())
    # --- issue 14: optical markers ---
    mks = []
    for mk in (body_markers, hands_markers):
        if isinstance(mk, (str, Path)):
            from ..io.trajectories import read_trajectories

            mk = read_trajectories(mk)
        for w in getattr(mk, "warnings", ()):
            log.note(w)
        mks.append(mk)
    log.tick("read")
    return Inputs(bm, hm, cfg, *mks)
