"""Exceptions raised by splicer.

Every error a user can cause derives from :class:`SplicerError`; the CLI prints its
message on one line and exits with status 1.  Messages name the file, line, joint or
constraint at fault.
"""

from __future__ import annotations


class SplicerError(Exception):
    """Base class of every error caused by user input (files, options, constraints)."""


class BVHError(SplicerError):
    """A BVH file cannot be read or written.

    Parameters
    ----------
    message : str
        What is wrong.
    path : str, optional
        The file at fault.
    line : int, optional
        1-based line number in that file.
    """

    def __init__(self, message: str, *, path: str | None = None, line: int | None = None):
        self.path = path
        self.line = line
        where = ""
        if path is not None:
            where = f"{path}"
            if line is not None:
                where += f", line {line}"
            where += ": "
        super().__init__(where + message)


class RoleError(SplicerError):
    """A skeleton lacks a joint the splice needs (arm, wrist, fingers)."""


class ConstraintError(SplicerError):
    """User constraints are malformed, out of range, not increasing or infeasible."""


class BandError(SplicerError):
    """A DTW band is too narrow to connect the start and end through the constraints."""


class TrajectoryError(SplicerError):
    """A marker file (C3D, TRC, CSV) cannot be read or written, or lacks what is asked of it."""


class SplicerWarning(UserWarning):
    """Something in the input was odd but could be handled (e.g. extra BVH data rows)."""
