"""Bringing a generated mesh into its class's size range, and the one failure of a seed the
forge expects: `UnusableMesh`, raised where a generator's mesh cannot be used (it made no
geometry, no scale fits the range, decimation cannot reach the budget). The forge then tries
the next seed; any other exception is a bug and stops it.

Pure Python and numpy: the tests import it without Blender.
"""

import math


class UnusableMesh(Exception):
    """The mesh a generator made for one seed cannot be used; the message says why."""


def fit(dims, size_range, stretch=False):
    """The scale (x, y, z) that brings an object of `dims` into `size_range`: uniform, the
    smallest change that fits (up to 15 % short of the range where nothing fits exactly, the
    geometric mean then); with `stretch`, where no uniform scale fits, the thinnest axis is
    scaled on its own (a rug's thickness, a picture's depth) and the other two uniformly.
    None when nothing fits."""
    lows = [r[0] / d for r, d in zip(size_range, dims)]
    highs = [r[1] / d for r, d in zip(size_range, dims)]

    def uniform(axes):
        s_lo, s_hi = max(lows[a] for a in axes), min(highs[a] for a in axes)
        if s_lo > s_hi * 1.15:  # needs a stretch beyond what a uniform scale can give
            return None
        return min(max(1.0, s_lo), s_hi) if s_lo <= s_hi else math.sqrt(s_lo * s_hi)

    every = (0, 1, 2)
    if not stretch or max(lows) <= min(highs):
        scale = uniform(every)
        return None if scale is None else (scale, scale, scale)
    thin = thinnest(dims)
    scale = uniform([a for a in every if a != thin])
    if scale is None:
        return None
    scales = [scale] * 3
    scales[thin] = min(max(scale, lows[thin]), highs[thin])
    return tuple(scales)


def thinnest(dims):
    """The axis of the smallest of `dims` (the first of equal ones, as numpy's argmin)."""
    return min(range(3), key=lambda a: (dims[a], a))
