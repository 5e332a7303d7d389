"""The numpy Gaussian filter against scipy's (the reference it replaces at run time)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d as scipy_gf

from splicer.filters import gaussian_filter1d


@pytest.mark.parametrize("sigma", [0.3, 1.0, 2.5, 7.0, 40.0])
@pytest.mark.parametrize("shape,axis", [((50,), 0), ((30, 4, 3), 0), ((6, 80), 1), ((3,), 0)])
@pytest.mark.parametrize("mode", ["nearest", "reflect"])
def test_equals_scipy(rng, sigma, shape, axis, mode):
    x = rng.normal(size=shape)
    np.testing.assert_allclose(gaussian_filter1d(x, sigma, axis=axis, mode=mode),
                               scipy_gf(x, sigma, axis=axis, mode=mode), rtol=1e-12, atol=1e-12)


def test_edge_cases():
    x = np.arange(5.0)
    out = gaussian_filter1d(x, 0)
    assert out.tolist() == x.tolist() and out is not x
    assert gaussian_filter1d(np.zeros((0, 3)), 2.0, axis=0).shape == (0, 3)
    with pytest.raises(ValueError, match="nearest"):
        gaussian_filter1d(x, 1.0, mode="wrap")
