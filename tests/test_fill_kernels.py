"""The fills' compiled helpers and exact shortcuts give what the NumPy they replace gives,
bit for bit (issue 13: the fills got cheaper, not different)."""

import cv2
import numpy as np
import pytest

from stereo_terrain._numeric import cross3, median, percentile
from stereo_terrain.stereo._manhattan_kernels import (
    fill_targets,
    finite_samples,
    hypothesis_costs,
    mostly_filled,
    outline_edges,
)
from stereo_terrain.stereo._regions import edge_support, fill_region_plane

SEEDS = range(12)


def _boxes(seed):
    """A random labelled image, a region of it and the box around it, as a slice of the
    frame (strided) or the whole frame (contiguous), with float32 disparities (NaN holes)
    and gradients."""
    rng = np.random.default_rng(seed)
    h, w = rng.integers(5, 60, 2)
    blur = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 2.0)
    labels = np.digitize(blur, np.quantile(blur, [0.3, 0.6])).astype(np.int32)
    disparity = rng.normal(20, 5, (h, w)).astype(np.float32)
    disparity[rng.random((h, w)) < 0.3] = np.nan
    gx = rng.normal(0, 15, (h, w)).astype(np.float32)
    gy = rng.normal(0, 15, (h, w)).astype(np.float32)
    filled = rng.random((h, w)) < 0.5
    box = (slice(1, h - 1), slice(2, w - 1)) if seed % 2 else (slice(None), slice(None))
    return rng, labels[box], disparity[box], gx[box], gy[box], filled[box]


@pytest.mark.parametrize("seed", SEEDS)
def test_edge_support_is_nonzero(seed):
    """Finite disparities on strong vertical edges near a region, in NumPy's order."""
    _, labels, disparity, gx, _, _ = _boxes(seed)
    near = cv2.dilate((labels == 1).view(np.uint8), np.ones((1, 5), np.uint8))
    thr = np.float32(12.0)
    for edges_only in (True, False):
        vs, us = edge_support(near, disparity, gx, thr, edges_only)
        mask = near.astype(bool) & np.isfinite(disparity) & ((np.abs(gx) > thr) | (not edges_only))
        ref = np.nonzero(mask)
        assert vs.dtype == ref[0].dtype and np.array_equal(vs, ref[0]) and np.array_equal(us, ref[1])


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("top", [6.5, None])
def test_fill_region_plane_as_numpy(seed, top):
    """The plane rounded to float32, written where it is above 0 (and below ``top``)."""
    rng, labels, _, _, _, _ = _boxes(seed)
    coef = rng.normal(0, [0.3, 0.3, 5.0])
    x0, y0 = 3, 2
    h, w = labels.shape
    out = np.full((h + y0, w + x0), np.nan, np.float32)
    filled = np.zeros(out.shape, bool)
    ref_out, ref_filled = out.copy(), filled.copy()
    fill_region_plane(labels, 1, x0, y0, coef, np.float32(top or 0), top is not None, out, filled)
    rv, ru = np.nonzero(labels == 1)
    plane = (coef[0] * (ru + x0) + coef[1] * (rv + y0) + coef[2]).astype(np.float32)
    keep = plane > 0
    if top is not None:
        keep &= plane < top
    ref_out[rv[keep] + y0, ru[keep] + x0] = plane[keep]
    ref_filled[rv[keep] + y0, ru[keep] + x0] = True
    assert out.tobytes() == ref_out.tobytes() and np.array_equal(filled, ref_filled)


@pytest.mark.parametrize("seed", SEEDS)
def test_manhattan_box_helpers_as_numpy(seed):
    """The share of a region filled, its finite samples, its outline's samples and the
    pixels its face fills."""
    _, labels, disparity, gx, gy, filled = _boxes(seed)
    region = labels == 1
    assert mostly_filled(filled, region) == (filled[region].mean() > 0.5)
    for most in (5, 300):
        vs, us = finite_samples(region, disparity, most)
        ref_v, ref_u = np.nonzero(region & np.isfinite(disparity))
        step = max(1, len(ref_u) // most)
        assert np.array_equal(vs, ref_v[::step]) and np.array_equal(us, ref_u[::step])
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    ring, core = cv2.dilate(region.view(np.uint8), kernel), cv2.erode(region.view(np.uint8), kernel)
    strong, cos_vertical = np.float32(12.0), np.float32(0.866)
    for stride in (1, 2, 3):
        got = outline_edges(ring, core, gx, gy, stride, strong, cos_vertical)
        ref_v, ref_u = np.nonzero(ring.astype(bool) & ~core.astype(bool))
        ref_v, ref_u = ref_v[::stride], ref_u[::stride]
        gxs, gys = gx[ref_v, ref_u], gy[ref_v, ref_u]
        m = np.hypot(gxs, gys)
        keep = (m > strong) & (np.abs(gxs) < m * cos_vertical)
        ref = (ref_v[keep], ref_u[keep], gxs[keep], gys[keep], m[keep])
        for a, b in zip(got, ref, strict=True):
            assert a.dtype == b.dtype and np.array_equal(a, b)
    large = np.array([False, True, True])
    for refit in (False, True):
        other = (labels != 1) & large[labels]
        held = filled & ~region if refit else filled
        ref = ring.astype(bool) & ~other & ~held
        assert np.array_equal(fill_targets(ring, labels, 1, large, filled, refit), ref)


@pytest.mark.parametrize("seed", range(40))
def test_order_statistics_as_numpy(seed):
    """Median and 2nd/98th percentiles (the Manhattan fill's) as NumPy's, bit for bit, ties
    and tiny sizes too."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400)) if seed >= 4 else seed + 1
    values = rng.normal(0, 50, n)
    if seed % 3 == 0:
        values = np.round(values)  # ties
    assert float(median(values)) == float(np.median(values))
    lo, hi = np.percentile(values, [2, 98])
    assert tuple(float(q) for q in percentile(values, [2, 98])) == (float(lo), float(hi))


def test_order_statistics_with_nan_as_numpy():
    """A NaN among the values gives NumPy's answer (NaN), not a middle value."""
    values = np.array([3.0, np.nan, 1.0, 2.0, 5.0])
    assert np.isnan(median(values)) and np.isnan(percentile(values, [2, 98])).all()


@pytest.mark.parametrize("seed", SEEDS)
def test_hypothesis_costs_as_numpy(seed):
    """MSAC's truncated costs summed as NumPy sums the residual matrix over its rows."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    target, g = rng.normal(30, 5, n), rng.normal(1, 0.2, n)
    idx = np.flatnonzero(rng.random(n) < 0.7)
    hyp = rng.normal(30, 5, 32)
    residual = target[idx, None] - hyp[None, :] * g[idx, None]
    ref = np.minimum(residual**2, 0.75**2).sum(axis=0)
    assert hypothesis_costs(target, g, idx, hyp, 0.75**2).tobytes() == ref.tobytes()


@pytest.mark.parametrize("seed", range(10))
def test_cross_as_numpy(seed):
    """The cross product of 3-vectors as NumPy's, bit for bit (signed zeros too)."""
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, 3)) * 10.0 ** rng.integers(-3, 3, (2, 3))
    if seed == 0:
        a, b = np.array([0.0, -0.0, 1.0]), np.array([-0.0, 1.0, 0.0])
    assert cross3(a, b).tobytes() == np.cross(a, b).tobytes()
