import cv2
import numpy as np
import pytest

from stereo_terrain.stereo._regions import connected_regions


@pytest.mark.parametrize("seed", range(20))
def test_connected_regions_equal_opencv(seed):
    """Labels and statistics as ``cv2.connectedComponentsWithStats`` gives them."""
    rng = np.random.default_rng(seed)
    h, w = rng.integers(1, 200, 2)
    noise = rng.random((h, w)).astype(np.float32)
    binary = (cv2.GaussianBlur(noise, (0, 0), rng.uniform(0.3, 4.0)) > rng.uniform(0.3, 0.7)).astype(np.uint8)
    count, labels, stats = connected_regions(binary)
    ref_count, ref_labels, ref_stats, _ = cv2.connectedComponentsWithStats(binary, connectivity=4)
    assert count == ref_count and stats.dtype == np.int32 and labels.dtype == np.int32
    assert np.array_equal(labels, ref_labels) and np.array_equal(stats, ref_stats)


@pytest.mark.parametrize("value", [0, 1])
def test_uniform_images_as_opencv(value):
    """All background, and all foreground (the background label has no pixel)."""
    binary = np.full((7, 9), value, np.uint8)
    count, labels, stats = connected_regions(binary)
    ref = cv2.connectedComponentsWithStats(binary, connectivity=4)
    assert count == ref[0] and np.array_equal(labels, ref[1]) and np.array_equal(stats, ref[2])
