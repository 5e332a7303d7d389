"""The data model: skeletons, motions, rotations, forward kinematics."""

from .motion import Motion, Skeleton

__all__ = ["Motion", "Skeleton"]
