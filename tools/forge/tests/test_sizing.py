"""sizing.py: the scale that brings a generated mesh into its class's size range."""

import numpy as np
import pytest

from sizing import fit, thinnest

CHAIR = ((0.4, 0.55), (0.42, 0.6), (0.8, 1.0))
RUG = ((1.2, 2.4), (1.6, 3.0), (0.01, 0.02))


def test_a_fitting_object_keeps_its_size():
    assert fit(np.array([0.5, 0.5, 0.9]), CHAIR) == (1.0, 1.0, 1.0)


def test_the_smallest_uniform_change_that_fits():
    # Too small by 10 % on its tightest axis: scaled up just enough.
    assert fit([0.36, 0.5, 0.9], CHAIR) == pytest.approx((0.4 / 0.36,) * 3)
    # Too large: scaled down just enough.
    assert fit([0.5, 0.5, 1.1], CHAIR) == pytest.approx((1.0 / 1.1,) * 3)


def test_within_fifteen_percent_the_geometric_mean():
    # Width wants >= 1.1, height <= 1.0: 10 % apart, the geometric mean of the two.
    scale = fit([0.4 / 1.1, 0.5, 1.0], CHAIR)
    assert scale == pytest.approx((1.1**0.5,) * 3)
    # 25 % apart: nothing fits.
    assert fit([0.4 / 1.25, 0.5, 1.0], CHAIR) is None


def test_stretch_scales_the_thinnest_axis_on_its_own():
    # A rug 2 × 2.5 m and 5 cm thick: no uniform scale fits; its thickness is scaled alone.
    assert fit([2.0, 2.5, 0.05], RUG) is None
    assert fit([2.0, 2.5, 0.05], RUG, stretch=True) == pytest.approx((1.0, 1.0, 0.4))


def test_thinnest_is_the_first_smallest_axis():
    assert [thinnest(d) for d in ([1, 2, 0.1], [0.3, 0.3, 1], [2, 1, 1])] == [2, 0, 1]
    assert thinnest(np.array([0.5, 0.2, 0.2])) == int(np.argmin([0.5, 0.2, 0.2]))
