"""Issue 13: hand-written replacements of small NumPy calls give NumPy's bits."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stereo_terrain._numeric import cross3
from stereo_terrain.msac import Plane


def test_cross3_is_np_cross_bit_for_bit():
    rng = np.random.default_rng(0)
    for _ in range(2000):
        a, b = rng.normal(size=3), rng.normal(size=3)
        a[rng.integers(3)] *= rng.choice([0.0, -0.0, 1.0])
        for other in (b, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
            assert cross3(a, other).tobytes() == np.cross(a, other).tobytes()


def test_plane_normalisation_is_np_linalg_norm():
    rng = np.random.default_rng(1)
    for _ in range(2000):
        n = rng.normal(size=3) * 10.0 ** rng.uniform(-4, 4)
        d = float(rng.normal())
        p = Plane(n, d)
        norm = float(np.linalg.norm(n))
        assert p.normal.tobytes() == (n / norm).tobytes() and p.offset == d / norm
        assert math.isclose(float(np.linalg.norm(p.normal)), 1.0)


def test_stacked_eigh_is_one_call_per_matrix():
    """The jackknife's stacked ``eigh`` gives each block what a call of its own gives."""
    rng = np.random.default_rng(2)
    A = rng.normal(size=(16, 3, 3))
    A = A + A.transpose(0, 2, 1)
    A[::3, 2, :] = A[::3, :, 2] = 0.0  # rank-deficient blocks too
    w, V = np.linalg.eigh(A)
    for b in range(len(A)):
        wb, Vb = np.linalg.eigh(A[b])
        assert wb.tobytes() == w[b].tobytes() and Vb.tobytes() == V[b].tobytes()


def test_median_is_nanmedian_without_nans():
    rng = np.random.default_rng(3)
    for n in range(1, 300):
        x = rng.random(n).astype(np.float32)
        assert float(np.median(x)) == float(np.nanmedian(x))


def test_percentile_is_np_percentile_bit_for_bit():
    from stereo_terrain._numeric import percentile

    rng = np.random.default_rng(4)
    for t in range(3000):
        n = int(rng.integers(1, 60)) if t % 10 else int(rng.integers(1, 3000))
        a = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3)
        if t % 5 == 0:
            a = np.round(a * 0.01, 0)  # ties, and -0.0 beside 0.0
        q = [2, 98] if t % 3 == 0 else float(rng.choice([0, 2, 2.5, 50, 98, 100, rng.uniform(0, 100)]))
        got, want = percentile(list(a) if t % 2 else a, q), np.percentile(a, q)
        assert type(got) is type(want) and np.asarray(got).tobytes() == np.asarray(want).tobytes()


def test_percentile_hands_other_input_to_numpy():
    from stereo_terrain._numeric import percentile

    a32 = np.array([3.0, 1.0, 2.0], np.float32)
    assert percentile(a32, 50) == np.percentile(a32, 50)
    assert np.isnan(percentile([1.0, np.nan, 2.0], 50))


def test_median_is_np_median_bit_for_bit():
    from stereo_terrain._numeric import median

    rng = np.random.default_rng(5)
    for t in range(3000):
        n = int(rng.integers(1, 80)) if t % 10 else int(rng.integers(1, 3000))
        a = rng.normal(size=(n, 3) if t % 2 else n) * 10.0 ** rng.uniform(-3, 3)
        if t % 5 == 0:
            a = np.round(a * 0.01, 0)  # ties, and -0.0 beside 0.0
        axis = 0 if a.ndim == 2 or t % 3 == 0 else None
        got, want = median(a, axis=axis), np.median(a, axis=axis)
        assert type(got) is type(want) and np.asarray(got).tobytes() == np.asarray(want).tobytes()
    assert np.isnan(median(np.array([1.0, np.nan])))


def test_median_of_float32_is_np_median_bit_for_bit():
    from stereo_terrain._numeric import median

    rng = np.random.default_rng(6)
    for t in range(2000):
        n = int(rng.integers(1, 80)) if t % 10 else int(rng.integers(1, 3000))
        a = (rng.normal(size=n) * 10.0 ** rng.uniform(-3, 3)).astype(np.float32)
        if t % 5 == 0:
            a = np.round(a * 0.01, 0)  # ties, and -0.0 beside 0.0
        got, want = median(a), np.median(a)
        assert type(got) is type(want) and np.asarray(got).tobytes() == np.asarray(want).tobytes()
    assert np.isnan(median(np.array([1.0, np.nan], np.float32)))


def test_disparity_from_fixed_point_is_the_numpy_passes_bit_for_bit():
    """Issue 13: the OpenCV backend's one compiled pass (scaling, OpenCV's invalid value,
    ``invalidate_sourceless``) gives the four NumPy passes' bits, half-pixel matches (ties
    of ``rint``) and matches off the image included."""
    import dataclasses

    from stereo_terrain.rectify import compute_rectification
    from stereo_terrain.stereo import invalidate_sourceless
    from stereo_terrain.stereo._disparity_kernels import disparity_from_fixed_point
    from stereo_terrain.stereo.opencv import _NO_MASK
    from stereo_terrain.synthetic import default_scene_spec, render_scene

    rectification = compute_rectification(render_scene(default_scene_spec()).calibration)
    w, h = rectification.image_size
    rng = np.random.default_rng(5)
    for t in range(6):
        raw = rng.integers(-20, 16 * 80, size=(h, w)).astype(np.int16)
        raw[:, :3] = rng.integers(0, 16 * 3, size=(h, 3)) // 8 * 8  # x - d on .5: rint's ties
        masks = [rng.random((h, w)) < 0.9 if t & 1 else None, rng.random((h, w)) < 0.9 if t & 2 else None]
        r = dataclasses.replace(rectification, valid_left=masks[0], valid_right=masks[1])
        want = raw.astype(np.float32)
        want *= np.float32(1.0 / 16.0)
        np.copyto(want, np.float32(np.nan), where=raw < 0)
        invalidate_sourceless(want, r)
        got = disparity_from_fixed_point(raw, *(_NO_MASK if m is None else m for m in masks))
        assert got.dtype == np.float32 and got.tobytes() == want.tobytes()


def test_planes_from_triplets_is_np_cross_and_norm_bit_for_bit():
    from stereo_terrain.msac import planes_from_triplets

    rng = np.random.default_rng(6)
    for t in range(1000):
        k = int(rng.integers(0, 70))
        dtype = np.float32 if t % 3 == 0 else np.float64
        p0, p1, p2 = ((rng.normal(size=(k, 3)) * 10.0 ** rng.uniform(-3, 3)).astype(dtype) for _ in range(3))
        if t % 5 == 0:
            p2 = p1.copy()  # collinear
        n = np.cross(p1 - p0, p2 - p0)
        norm = np.linalg.norm(n, axis=1)
        ok = norm > 1e-9
        n = n / np.where(ok, norm, 1.0)[:, None]
        want = (n, -np.einsum("ij,ij->i", n, p0), ok)
        got = planes_from_triplets(p0, p1, p2)
        assert all(g.dtype == w.dtype and g.tobytes() == w.tobytes() for g, w in zip(got, want, strict=True))


def test_box_means_masks_are_the_numpy_ones_bit_for_bit():
    """cloud._box_means masks the disparities by cv2.bitwise_and and makes its 0/1 bytes
    by cv2.threshold (issue 13): np.where's and np.minimum's bits."""
    import cv2

    rng = np.random.default_rng(7)
    for _ in range(20):
        dd = rng.uniform(-5.0, 90.0, (61, 83)).astype(np.float32)
        dd[rng.random(dd.shape) < 0.2] = np.nan
        dd[rng.random(dd.shape) < 0.05] = -0.0
        dd[rng.random(dd.shape) < 0.02] = np.inf
        in_range = cv2.inRange(dd, 0.0, 60.0)
        want_valid = np.minimum(in_range, 1)
        want = np.where(want_valid.view(bool), dd, np.float32(0.0))
        got = cv2.bitwise_and(dd, dd, mask=in_range)
        cv2.threshold(in_range, 0, 1, cv2.THRESH_BINARY, dst=in_range)
        assert got.tobytes() == want.tobytes() and in_range.tobytes() == want_valid.tobytes()


def test_truncated_family_error_sums_are_the_numpy_passes_bit_for_bit():
    """estimate_up's hypothesis scores by one compiled pass (issue 13): NumPy's column sums
    of the truncated squared sines, bit for bit, for two hypotheses or more (NumPy sums a
    single column pairwise: estimate_up keeps NumPy's passes there)."""
    from stereo_terrain.gravity._kernels import truncated_family_error_sums

    rng = np.random.default_rng(8)
    s2 = np.float32(math.sin(math.radians(10.0)) ** 2)
    for t in range(200):
        S, H = int(rng.integers(1, 2500)), int(rng.integers(2, 320))
        N = rng.normal(size=(S, 3))
        N /= np.linalg.norm(N, axis=1, keepdims=True)
        U = rng.normal(size=(H, 3))
        U /= np.linalg.norm(U, axis=1, keepdims=True)
        if t % 5 == 0:
            N[: S // 2] = U[0]  # exact family members: cosines of +-1
        cosines = N.astype(np.float32) @ U.T.astype(np.float32)
        D2 = np.square(cosines)
        err = np.minimum(1.0 - D2, D2)
        np.minimum(err, s2, out=err)
        want = err.sum(axis=0)
        got = truncated_family_error_sums(cosines, s2)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()


def test_floor_inlier_counts_are_the_numpy_passes():
    """floor_up's hypothesis counts by one compiled pass (issue 13): NumPy's counts, with
    residuals and cosines placed exactly on the thresholds too."""
    from stereo_terrain.gravity._kernels import floor_inlier_counts

    rng = np.random.default_rng(9)
    for t in range(200):
        H, S = int(rng.integers(1, 60)), int(rng.integers(0, 400))
        dots = rng.normal(scale=0.05, size=(H, S))
        offsets = rng.normal(scale=0.05, size=H)
        thr = rng.uniform(0.015, 0.06, size=S).astype(np.float32)
        cosines = rng.uniform(-1.0, 1.0, size=(H, S))
        if t % 4 == 0 and S:  # on the boundaries
            dots[:, : S // 2] = thr[: S // 2].astype(np.float64) - offsets[:, None]
            cosines[:, S // 3 :] = rng.choice([0.9, -0.9], size=(H, S - S // 3))
        want = ((np.abs(dots + offsets[:, None]) < thr) & (np.abs(cosines) >= 0.9)).sum(axis=1)
        got = floor_inlier_counts(dots, offsets, thr, cosines, 0.9)
        assert got.tolist() == want.tolist()


@settings(max_examples=200, deadline=None)
@given(
    st.integers(1, 30),
    st.lists(
        st.tuples(st.integers(0, 29), st.floats(-3.0, 3.0, allow_nan=False).map(lambda v: round(v, 2))),
        max_size=200,
    ),
)
def test_slice_spans_are_the_per_slice_percentiles(n_slices, samples):
    """A wall's slices' height spans in one sort give what a mask and ``percentile`` per
    slice give (terrain/risers.py, ``_riser_beside_wall``), ties included."""
    from stereo_terrain._numeric import percentile
    from stereo_terrain.terrain.risers import _slice_spans

    which = np.array([w % n_slices for w, _ in samples], dtype=np.int64)
    z = np.array([v for _, v in samples], dtype=np.float64)
    spans = _slice_spans(z, which, n_slices)
    for k in range(n_slices):
        zk = z[which == k]
        if len(zk) < 3:
            assert np.isnan(spans[k])
        else:
            lo, hi = percentile(zk, [2, 98])
            assert spans[k] == hi - lo


@settings(max_examples=200, deadline=None)
@given(
    st.integers(1, 20),
    st.lists(st.tuples(st.integers(0, 19), st.floats(-1e3, 1e3, allow_nan=False)), max_size=150),
    st.lists(st.floats(0.0, 100.0), min_size=1, max_size=4),
    st.integers(1, 4),
)
def test_group_percentile_is_np_percentile_per_group(n_groups, samples, qs, min_count):
    """The same values as ``np.percentile`` group by group (compared with ``==``: a zero's
    sign may differ, equal values being ordered by a sort rather than a partition)."""
    from stereo_terrain._numeric import group_percentile

    groups = np.array([g % n_groups for g, _ in samples], dtype=np.int64)
    values = np.array([v for _, v in samples], dtype=np.float64)
    got = group_percentile(values, groups, n_groups, qs, min_count=min_count)
    assert got.shape == (len(qs), n_groups)
    for k in range(n_groups):
        vk = values[groups == k]
        if len(vk) < min_count or len(vk) == 0:
            assert np.isnan(got[:, k]).all()
        else:
            assert np.array_equal(got[:, k], np.percentile(vk, qs))
