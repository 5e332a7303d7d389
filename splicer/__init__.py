"""splicer: splice separately captured finger motion onto full-body motion capture.

The method is Majkowska, Zordan & Faloutsos, "Automatic Splicing for Hand and Body
Animations" (SCA 2006): virtual markers on wrist, forearm and hand; a banded DTW pass with a
derivative-sign phase metric; a narrower pass with a palm-angle metric; user constraints;
merge; BVH out.
"""

__version__ = "0.1.0"

from .errors import BandError, BVHError, ConstraintError, RoleError, SplicerError  # noqa: E402
from .model import Motion, Skeleton  # noqa: E402


def __getattr__(name):  # lazy: importing splicer does not load numba kernels or bvhio
    if name in ("read_bvh", "write_bvh"):
        from . import bvh

        return getattr(bvh, name)
    if name in ("splice", "SpliceResult", "SpliceOptions"):
        from . import splice as _s

        return getattr(_s, name)
    if name == "find_roles":
        from .roles import find_roles

        return find_roles
    raise AttributeError(f"module 'splicer' has no attribute {name!r}")


__all__ = ["BVHError", "BandError", "ConstraintError", "Motion", "RoleError", "Skeleton", "SplicerError",
           "find_roles", "read_bvh", "splice", "write_bvh", "__version__"]
