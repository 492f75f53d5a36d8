"""The project's own SGM engine: accuracy on known shifts, robustness to gain, bad input."""

import re

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.rectify import RectifiedPair
from stereo_terrain.stereo import make_backend
from stereo_terrain.stereo.sgm import SGM, SGMConfig, census5x5
from stereo_terrain.synthetic import default_scene_spec, render_scene

from .test_stereo import _shifted_pair

SUBPIXEL_TOL_PX = 0.25


@pytest.fixture(scope="module")
def shifted():
    return _shifted_pair(12.5)


def test_known_disparity(shifted):
    dm = SGM().compute(shifted, 64)
    d = dm.disparity[:, 80:]
    assert dm.backend == "sgm" and dm.density > 0.8
    assert np.nanmedian(np.abs(d - 12.5)) < SUBPIXEL_TOL_PX
    cols = np.arange(640)[None, :]
    assert not (dm.disparity > cols).any()  # never matched outside the right image
    assert not (dm.disparity == 0).any()  # invalid is NaN, never 0
    assert dm.confidence is not None and dm.confidence.shape == d.shape[:1] + (640,)


def test_census_cost_ignores_gain_and_offset(shifted):
    right = np.clip(shifted.right.astype(np.float32) * 0.8 + 20, 0, 255).astype(np.uint8)
    dm = SGM().compute(RectifiedPair(shifted.left, right, shifted.rectification), 64)
    assert np.nanmedian(np.abs(dm.disparity[:, 80:] - 12.5)) < SUBPIXEL_TOL_PX
    # A monotonic brightness change leaves the census unchanged (away from saturation).
    img = (shifted.left // 2).astype(np.uint8)
    assert np.array_equal(census5x5(img), census5x5(img + np.uint8(40)))


@pytest.mark.parametrize("paths", [4, 16])
def test_path_counts(shifted, paths):
    dm = SGM(SGMConfig(paths=paths)).compute(shifted, 32)
    assert np.nanmedian(np.abs(dm.disparity[:, 80:] - 12.5)) < SUBPIXEL_TOL_PX


def test_bad_input(shifted):
    for paths in (6, 12):
        with pytest.raises(ConfigError):
            SGMConfig(paths=paths)
    with pytest.raises(ConfigError):
        SGMConfig(p1=50, p2=10)
    with pytest.raises(ConfigError):
        SGM().compute(shifted, 40)  # not a multiple of 16
    bad = RectifiedPair(shifted.left.astype(np.float32), shifted.right, shifted.rectification)
    with pytest.raises(InputError, match="uint8"):
        SGM().compute(bad, 64)
    assert make_backend("sgm").name == "sgm"


def test_rendered_staircase_through_the_pipeline():
    scene = render_scene(default_scene_spec())
    result = Pipeline(scene.calibration, scene.rig, PipelineConfig(backend="sgm")).run(
        scene.left, scene.right
    )
    data = result.to_json_dict()
    assert data["obstacle"] == "stairs" and len(data["steps"]) == 3
    for got, want in zip(data["steps"], scene.truth["steps"], strict=True):
        assert abs(got["rise"] - want["rise"]) < 0.015
        assert abs(got["distance"] - want["distance"]) < 0.03


def _paper_recurrence(cost, img, dy, dx, p1, p2, scale):
    """L_r of Hirschmüller's eq. by the letter (slow), for one direction."""
    h, w, n = cost.shape
    L = np.zeros((h, w, n), int)
    for y in range(h) if dy >= 0 else range(h - 1, -1, -1):
        for x in range(w) if dx >= 0 else range(w - 1, -1, -1):
            py, px, c = y - dy, x - dx, cost[y, x].astype(int)
            if not (0 <= py < h and 0 <= px < w):
                L[y, x] = c
                continue
            prev = L[py, px]
            pm = prev.min()
            p2a = max(p1 + 1, int(p2 / (1 + abs(int(img[y, x]) - int(img[py, px])) / scale)))
            for d in range(n):
                best = min(prev[d], pm + p2a)
                if d > 0:
                    best = min(best, prev[d - 1] + p1)
                if d < n - 1:
                    best = min(best, prev[d + 1] + p1)
                L[y, x, d] = c[d] + best - pm
    return L


@pytest.mark.parametrize("forward", [True, False])
@pytest.mark.parametrize("paths", [4, 8, 16])
@pytest.mark.parametrize("height", [7, 3])  # several row groups, and fewer rows than one
def test_sweeps_match_the_paper_recurrence(forward, paths, height):
    from stereo_terrain.stereo.sgm import ROW_PATHS, aggregate_sweep, census_cost, p2_table, sweep_state

    rng = np.random.default_rng(4)
    left = rng.integers(0, 255, (height, 11)).astype(np.uint8)
    right = rng.integers(0, 255, (height, 11)).astype(np.uint8)
    cl, cr = census5x5(left), census5x5(right)
    cost = census_cost(cl, cr, 9)
    s = 1 if forward else -1
    dirs = [(0, s)] + [(s * b, s * c) for b, c in ROW_PATHS[paths]]
    want = sum(_paper_recurrence(cost, left, dy, dx, 7, 86, 16.0) for dy, dx in dirs)
    rows = np.array(ROW_PATHS[paths], dtype=np.int64)
    lut = p2_table(7, 86, 16.0)
    no_selection = (False, 0.05, 1.0, np.empty((height, 11), np.float32), np.empty((height, 11), np.float32))
    got = np.full(cost.shape, 5, dtype=np.int16)
    aggregate_sweep(
        cl, cr, left, forward, rows, lut, 7, got, 0, height, False, sweep_state(11, 9, paths), *no_selection
    )
    assert np.array_equal(got.astype(int), want)
    # In two calls, the second going on from the first's state and adding to what it finds.
    got = np.full(cost.shape, 5, dtype=np.int16)
    state = aggregate_sweep(
        cl, cr, left, forward, rows, lut, 7, got, 0, 2, False, sweep_state(11, 9, paths), *no_selection
    )
    aggregate_sweep(cl, cr, left, forward, rows, lut, 7, got, 2, height, True, state, *no_selection)
    done = np.arange(height) < 2 if forward else np.arange(height) >= height - 2
    assert np.array_equal(got[done].astype(int), want[done])
    assert np.array_equal(got[~done].astype(int), 5 + want[~done])


# Bounds from `stereo-terrain eval-disparity` on the shared Middlebury scenes (our engine
# measured 5.8% and 6.4%; OpenCV StereoSGBM's best mode 14.7% and 13.4%).
MIDDLEBURY_BAD2_MAX = {"Teddy": 0.08, "Motorcycle": 0.08}


@pytest.mark.parametrize("scene", sorted(MIDDLEBURY_BAD2_MAX))
def test_middlebury_bad2_bound(shared_data, scene):
    import cv2

    from stereo_terrain.calibration import read_calibration
    from stereo_terrain.evaluation import disparity_errors
    from stereo_terrain.rectify import compute_rectification, read_image, rectify
    from stereo_terrain.stereo import default_max_disparity
    from stereo_terrain.stereo.io import read_pfm

    d = shared_data / "middlebury2014Q" / scene
    rect = compute_rectification(read_calibration(d / "calib.txt"))
    pair = rectify(read_image(d / "im0.png"), read_image(d / "im1.png"), rect)
    dm = SGM().compute(pair, default_max_disparity(rect, 0.7))
    nocc = cv2.imread(str(d / "mask0nocc.png"), cv2.IMREAD_GRAYSCALE) == 255
    errors = disparity_errors(dm.disparity, read_pfm(d / "disp0GT.pfm"), nocc)
    assert errors["bad2"] < MIDDLEBURY_BAD2_MAX[scene], errors


def test_pfm_round_trip_and_disparity_files(tmp_path):
    from stereo_terrain.stereo.io import read_pfm, write_disparity

    d = np.array([[1.5, np.nan], [3.25, 4.0]], np.float32)
    write_disparity(tmp_path / "d.pfm", d)
    back = read_pfm(tmp_path / "d.pfm")
    assert back[0, 0] == 1.5 and np.isinf(back[0, 1]) and back[1, 0] == 3.25
    assert (tmp_path / "d.pfm").read_bytes().startswith(b"Pf\n2 2\n-1.0\n")
    write_disparity(tmp_path / "d.npy", d)
    write_disparity(tmp_path / "d.png", d)
    with pytest.raises(InputError, match="unknown disparity file type"):
        write_disparity(tmp_path / "d.bmp", d)
    with pytest.raises(InputError, match="not found"):
        read_pfm(tmp_path / "none.pfm")


def test_disparity_and_eval_commands(shared_data, tmp_path, capsys):
    from stereo_terrain.cli import main

    d = shared_data / "middlebury2014Q" / "Teddy"
    code = main(
        [
            "disparity",
            str(d / "im0.png"),
            str(d / "im1.png"),
            "--calib",
            str(d / "calib.txt"),
            "--method",
            "sgm",
            "--out",
            str(tmp_path / "t.pfm"),
        ]
    )
    assert code == 0 and (tmp_path / "t.pfm").is_file()
    code = main(["eval-disparity", str(d), "--method", "opencv"])
    out = capsys.readouterr().out
    assert code == 0 and "| Teddy | opencv |" in out and "| mean | opencv |" in out
    assert main(["eval-disparity", str(tmp_path)]) == 2


@pytest.mark.parametrize("height", [1, 2, 5])
def test_tiny_images_match_the_two_phase_split(height):
    """The two sweeps split the rows in halves; with one or two rows a half is empty."""
    from stereo_terrain.stereo.sgm import census_cost, p2_table, select_disparity_rows
    from stereo_terrain.stereo.sgm.cuda import DIRECTIONS  # the 8 directions

    rng = np.random.default_rng(9)
    left = rng.integers(0, 255, (height, 40)).astype(np.uint8)
    right = np.roll(left, -2, axis=1)
    engine = SGM(SGMConfig(uniqueness_ratio_pct=0))
    c = engine.config
    lut = p2_table(c.p1, c.p2, c.p2_gradient_scale)
    got, _ = engine._compute_cpu(left, left, right, 16, lut)
    cost = census_cost(census5x5(left), census5x5(right), 16).astype(int)
    total = sum(
        _paper_recurrence(cost, left, dy, dx, c.p1, c.p2, c.p2_gradient_scale) for dy, dx in DIRECTIONS
    )
    want = np.empty(left.shape, np.float32)
    select_disparity_rows(total.astype(np.int16), 0, height, 0.0, c.lr_max_diff_px, want, want.copy())
    assert np.array_equal(got, want, equal_nan=True)
    assert np.isfinite(got).any()


def test_pipeline_config_passes_sgm_options():
    config = PipelineConfig.from_dict({"backend": "sgm", "sgm": {"paths": 4, "device": "cpu"}})
    assert config.sgm == SGMConfig(paths=4)
    with pytest.raises(ConfigError, match="sgm"):
        PipelineConfig.from_dict({"sgm": {"paths": 5}})


def test_engine_reuses_its_volume_across_frames_and_sizes(shifted):
    """S is kept between calls; a call of another size or range must not see stale sums."""
    engine = SGM()
    small = RectifiedPair(
        shifted.left[:40, :120].copy(), shifted.right[:40, :120].copy(), shifted.rectification
    )
    first = engine.compute(shifted, 32).disparity
    for pair, n in ((small, 16), (shifted, 48), (shifted, 32)):
        got = engine.compute(pair, n).disparity
        assert np.array_equal(got, SGM().compute(pair, n).disparity, equal_nan=True)
    assert np.array_equal(got, first, equal_nan=True)


def test_noalias_flag_reaches_llvm():
    """The engine's speed depends on Numba honouring ``noalias`` (see _allow_noalias_option);
    a Numba upgrade that drops it gives the same disparities, 3x slower: fail loudly here."""
    from numba import njit

    from stereo_terrain.stereo.sgm import NOALIAS

    assert NOALIAS

    def add_into(a, b):
        for i in range(a.size):
            a[i] += b[i]

    def data_pointer_is_noalias(**flags) -> bool:
        f = njit(**flags)(add_into)
        f(np.zeros(4), np.ones(4))
        # Numba passes an array as its fields; the fifth (".4") is the data pointer.
        # ("ptr noalias ..." with LLVM's opaque pointers, "double* noalias ..." before them)
        return re.search(r"noalias [^%,]*%arg\.a\.4", f.inspect_llvm(f.signatures[0])) is not None

    assert data_pointer_is_noalias(noalias=True) and not data_pointer_is_noalias()


def test_census_blur_option(shifted):
    """The blur changes what the census sees (not the known shift), and bad values are refused."""
    sharp = SGM().compute(shifted, 32).disparity
    blurred = SGM(SGMConfig(census_blur_sigma_px=1.0)).compute(shifted, 32).disparity
    assert not np.array_equal(sharp, blurred, equal_nan=True)
    inner = blurred[40:-40, 80:-40]
    assert np.nanmedian(np.abs(inner - 12.5)) < SUBPIXEL_TOL_PX and np.isfinite(inner).mean() > 0.9
    for bad in (-1.0, 11.0):
        with pytest.raises(ConfigError, match="census_blur_sigma_px"):
            SGMConfig(census_blur_sigma_px=bad)


def test_sweep_threads_keep_to_their_own_cpus():
    """Each of the two sweep threads keeps to its own half of the CPUs (where there are two)."""
    import os

    from stereo_terrain.stereo.sgm import cpu_halves, sweep_pool

    halves = cpu_halves()
    if not halves:
        pytest.skip("fewer than two CPUs, or no CPU affinity on this system")
    assert not (halves[0] & halves[1]) and halves[0] | halves[1] == os.sched_getaffinity(0)
    pool = sweep_pool()
    import threading

    barrier = threading.Barrier(2)  # both threads busy at once: one job each

    def where() -> frozenset[int]:
        barrier.wait(timeout=10)
        return frozenset(os.sched_getaffinity(0))

    seen = {job.result() for job in [pool.submit(where) for _ in range(2)]}
    assert seen == {frozenset(h) for h in halves}
