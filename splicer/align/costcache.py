"""Pass 1's local costs, kept once computed, for the stages that read them again.

Pass 1's band-chunk cost (D1, :func:`splicer.align.costs.d1_cost`) is the dearest part of a
splice: 0.1-0.3 microseconds a cell (two threads; more under load), tens of millions of cells
on a long take.  After the DTW two more stages read the same cells: the expected path (:mod:`splicer.align.posterior`, a
tube around the best path inside the pass's band) and the confidence
(:mod:`splicer.align.confidence`, the whole band, twice).  Both store the costs as float32,
so a float32 copy of what the DTW computed gives them exactly the values they would compute
again.  :class:`CachedBandCost` keeps that copy, within a byte budget, and serves it.

The DTW itself always gets the freshly computed float64 values (the cache fills as it runs);
later calls on cached rows get the float32 values widened to float64, which the two readers
round back to the same float32.
"""

from __future__ import annotations

import numpy as np

from .band import Band

__all__ = ["CachedBandCost", "CACHE_BYTES"]

#: Pass 1 keeps at most this many bytes of local costs (4 bytes a band cell): 64 million
#: cells, a 20-minute take at 60 fps in a band of about 880 body frames.  Rows past the
#: budget are computed again by each reader, as without a cache.
CACHE_BYTES = 256 << 20


class CachedBandCost:
    """A band-chunk cost ``(band, i0, i1) -> np.ndarray`` that keeps its own band's rows.

    Parameters
    ----------
    cost : callable ``(band, i0, i1) -> np.ndarray [shape=(i1 - i0, >= band.max_row_width)]``
        The cost to wrap (float64, ``+inf`` past each row's width).
    band : Band
        The band whose cells are kept: the pass's own.
    budget_bytes : int
        At most this many bytes are kept (float32): the first rows of the band whose cells fit.

    Notes
    -----
    Rows are kept as the DTW asks for them (in increasing order, each once); a later call on
    ``band`` or on a band lying inside it (the expected path's tube), for rows already kept,
    is served from the copy without calling ``cost``.  Anything else goes to ``cost``.
    O(min(band cells, budget / 4)) memory; :meth:`release` frees it.
    """

    def __init__(self, cost, band: Band, *, budget_bytes: int):
        self.cost = cost
        self.band = band
        widths = band.hi - band.lo + 1
        self._off = np.zeros(band.n + 1, np.int64)
        np.cumsum(widths, out=self._off[1:])
        # rows 0 .. limit-1 fit in the budget
        self._limit = int(np.searchsorted(self._off, int(budget_bytes) // 4, side="right")) - 1
        self._flat = np.empty(int(self._off[self._limit]), np.float32) if self._limit > 0 else None
        self._filled = 0  # rows 0 .. filled-1 are kept

    @property
    def kept_rows(self) -> int:
        """Number of leading rows of :attr:`band` whose costs are kept."""
        return self._filled

    @property
    def kept_bytes(self) -> int:
        """Bytes of costs kept now."""
        return 4 * int(self._off[self._filled])

    def release(self) -> None:
        """Free the kept costs; later calls compute everything again."""
        self._flat = None
        self._filled = 0
        self._limit = 0

    def covers(self, band: Band, i0: int, i1: int) -> bool:
        """True when rows ``i0 .. i1-1`` of ``band`` are served from the copy."""
        if i1 > self._filled or i0 < 0:
            return False
        if band is self.band:
            return True
        own = self.band
        return (band.n == own.n and band.m == own.m
                and bool(np.all(band.lo[i0:i1] >= own.lo[i0:i1])) and bool(np.all(band.hi[i0:i1] <= own.hi[i0:i1])))

    def __call__(self, band: Band, i0: int, i1: int) -> np.ndarray:
        if self.covers(band, i0, i1):
            return self._serve(band, i0, i1)
        out = self.cost(band, i0, i1)
        if band is self.band and i0 == self._filled and self._flat is not None and i0 < self._limit:
            self._keep(out, i0, min(i1, self._limit))
        return out

    def _keep(self, block: np.ndarray, i0: int, i1: int) -> None:
        off, own = self._off, self.band
        w = own.hi[i0:i1] - own.lo[i0:i1] + 1
        dst = self._flat[off[i0]:off[i1]]
        if w.min() == w.max():  # rows of one width (most of a band): no boolean mask
            dst[:] = block[:i1 - i0, :w[0]].reshape(-1)
        else:
            dst[:] = block[:i1 - i0][np.arange(block.shape[1])[None, :] < w[:, None]]
        self._filled = i1

    def _serve(self, band: Band, i0: int, i1: int) -> np.ndarray:
        own, off = self.band, self._off
        width = band.max_row_width
        if band is own:
            w = own.hi[i0:i1] - own.lo[i0:i1] + 1
            out = np.full((i1 - i0, width), np.inf)
            out[np.arange(width)[None, :] < w[:, None]] = self._flat[off[i0]:off[i1]]
            return out
        cols = band.lo[i0:i1, None] + np.arange(width)[None, :]
        valid = cols <= band.hi[i0:i1, None]
        src = off[i0:i1, None] + (cols - own.lo[i0:i1, None])
        src = np.where(valid, src, off[i0:i1, None])  # any kept index; masked below
        out = self._flat[src].astype(np.float64)
        out[~valid] = np.inf
        return out
