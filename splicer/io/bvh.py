"""Reading and writing BVH motion-capture files (the only package part that imports ``bvhio``).

* :func:`read_bvh` (:mod:`splicer.io.bvh_read`): the bytes are read once; the header is
  decoded and scanned line by line (:mod:`splicer.io.bvh_header`, every complaint a
  :class:`~splicer.errors.BVHError` with the 1-based line) and cross-checked against bvhio,
  the parser of record; the motion rows are parsed in place by the compiled parser of
  :mod:`splicer.io.fastparse`, values equal to ``float(token)`` bit for bit.
* :func:`write_bvh` (:mod:`splicer.io.bvh_write`): the header as text, the motion block as
  ``%.12g`` by the compiled formatter of :mod:`splicer.io.fastformat`, streamed into a
  temporary file moved into place atomically (:mod:`splicer.io.atomic`).

Reading then writing reproduces a typical file digit for digit (values with at most 12
significant digits); the hierarchy (names, offsets, channel order, End Sites) exactly.
"""

from __future__ import annotations

import os  # noqa: F401  (tests patch os.replace through this module)

from .bvh_header import load_bvhio as _bvhio  # noqa: F401
from .bvh_read import read_bvh
from .bvh_write import write_bvh

__all__ = ["read_bvh", "write_bvh"]
