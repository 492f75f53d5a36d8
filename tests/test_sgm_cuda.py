"""The SGM engine's CUDA path: same result as the CPU, checked on Numba's CUDA simulator
(runs anywhere) and, in the tests marked ``gpu``, on a real device."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereo_terrain.errors import ConfigError
from stereo_terrain.stereo.sgm import SGM, SGMConfig
from stereo_terrain.stereo.sgm.cuda import DIRECTIONS, cuda_available, disparity_cuda, line_starts

from .test_stereo import _shifted_pair

needs_gpu = pytest.mark.skipif(not cuda_available(), reason="no CUDA device")

# Run in a child process: the simulator is chosen when numba.cuda is first imported.
_SIMULATED = textwrap.dedent(
    """
    import numpy as np
    from stereo_terrain.stereo.sgm import SGM, census5x5, p2_table
    from stereo_terrain.stereo.sgm.cuda import disparity_cuda

    rng = np.random.default_rng(3)
    left = rng.integers(0, 255, (4, 14)).astype(np.uint8)
    right = np.clip(np.roll(left, -3, axis=1) + rng.integers(-3, 4, left.shape), 0, 255).astype(np.uint8)
    engine = SGM()
    c = engine.config
    lut = p2_table(c.p1, c.p2, c.p2_gradient_scale)
    want = engine._compute_cpu(left, left, right, 16, lut)
    got = disparity_cuda(census5x5(left), census5x5(right), left, 16, 8, lut, c.p1,
                         c.uniqueness_ratio_pct / 100, c.lr_max_diff_px)
    assert np.isfinite(want[0]).sum() >= 20, "too few matches to compare"
    assert np.array_equal(want[0], got[0], equal_nan=True), (want[0], got[0])
    assert np.array_equal(want[1], got[1])
    """
)


def test_cuda_kernels_match_the_cpu_on_the_simulator():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    done = subprocess.run([sys.executable, "-c", _SIMULATED], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]


@given(h=st.integers(1, 9), w=st.integers(1, 9), direction=st.sampled_from(DIRECTIONS))
def test_path_lines_cover_every_pixel_once(h, w, direction):
    dy, dx = direction
    seen = np.zeros((h, w), dtype=int)
    for y, x in zip(*line_starts(h, w, dy, dx), strict=True):
        while 0 <= y < h and 0 <= x < w:
            seen[y, x] += 1
            y, x = y + dy, x + dx
    assert (seen == 1).all()


def test_device_option_errors():
    with pytest.raises(ConfigError, match="device"):
        SGMConfig(device="tpu")
    one = np.zeros((4, 40), dtype=np.uint32)
    lut = np.zeros(256, dtype=np.int16)
    with pytest.raises(ConfigError, match="4 or 8 paths"):
        disparity_cuda(one, one, one.astype(np.uint8), 16, 16, lut, 7, 0.05, 1.0)
    with pytest.raises(ConfigError, match="at most 256"):
        disparity_cuda(one, one, one.astype(np.uint8), 272, 8, lut, 7, 0.05, 1.0)
    if not cuda_available():
        with pytest.raises(ConfigError, match="no CUDA device"):
            SGM(SGMConfig(device="cuda")).compute(_shifted_pair(5), 32)
        # auto falls back to the CPU
        assert SGM(SGMConfig(device="auto")).compute(_shifted_pair(5), 32).density > 0.5


@pytest.mark.gpu
@needs_gpu
def test_gpu_matches_cpu_on_a_shifted_texture():
    pair = _shifted_pair(7)
    cpu = SGM().compute(pair, 32)
    gpu = SGM(SGMConfig(device="cuda")).compute(pair, 32)
    assert np.array_equal(cpu.disparity, gpu.disparity, equal_nan=True)
    assert np.array_equal(cpu.confidence, gpu.confidence)
