"""The planar fill at occluding edges (issue 11): a face's outline carries its own
disparity or an occluder's, never a disparity behind it (stereo/fill.py)."""

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError
from stereo_terrain.stereo.fill import PlanarFillConfig, fill_planar_regions

WALL_PX, POST_PX = 10.0, 30.0
H, W = 200, 300


def _near_vertical_edges(image: np.ndarray, reach_px: int) -> np.ndarray:
    """Pixels within ``reach_px`` along their row of an intensity step: where a matcher has
    something to lock onto (the faces' interiors are uniform: NaN)."""
    step = np.zeros(image.shape, bool)
    step[:, 1:] = image[:, 1:] != image[:, :-1]
    out = step.copy()
    for k in range(1, reach_px + 1):
        out[:, k:] |= step[:, :-k]
        out[:, :-k] |= step[:, k:]
    return out


def _wall_behind_posts() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A uniform back wall between two darker side walls (its corners, at the wall's own
    disparity), with three bright posts in front of it up to 3/4 of the image.
    The matcher's disparity exists only next to vertical edges, and the posts' is fattened
    by 4 px onto the wall on either side (as block matching does). Returns the left
    image, the disparity and the wall's mask away from all edges."""
    left = np.full((H, W), 150, np.uint8)
    left[:, :40] = 60
    left[:, 260:] = 60
    posts = np.zeros((H, W), bool)
    for x in (70, 143, 215):
        posts[50:, x : x + 15] = True
    left[posts] = 230
    disp = np.full((H, W), WALL_PX, np.float32)
    fat = posts.copy()
    for k in range(1, 5):
        fat[:, k:] |= posts[:, :-k]
        fat[:, :-k] |= posts[:, k:]
    disp[fat] = POST_PX
    disp[~_near_vertical_edges(left, 6)] = np.nan
    wall = np.zeros((H, W), bool)
    wall[:40, 100:200] = True  # above the posts, far from every edge
    return left, disp, wall


def test_a_wall_seen_behind_posts_does_not_take_the_posts_plane():
    left, disp, wall = _wall_behind_posts()
    # The posts' fattened edges are most of the wall's outline support: plain MSAC glues
    # the wall to them (the old behaviour, kept by max_behind_ratio=1).
    glued, filled = fill_planar_regions(disp, left, PlanarFillConfig(max_behind_ratio=1.0))
    assert filled[wall].all()
    assert np.allclose(glued[wall], POST_PX, atol=0.5)
    # The wall's corners show a surface behind that plane: refused, the wall left alone.
    values, filled = fill_planar_regions(disp, left)
    assert not filled[wall].any()
    assert np.isnan(values[wall]).all()


def test_a_face_whose_silhouette_ring_reaches_the_background_is_still_filled():
    """Behind points next to the plane's own inliers are the ring of the face's silhouette
    reaching the background, not a surface behind the face."""
    left = np.full((H, W), 60, np.uint8)
    face = np.zeros((H, W), bool)
    face[40:160, 80:220] = True
    left[face] = 200
    disp = np.full((H, W), WALL_PX, np.float32)
    grown = face.copy()  # the face's disparity fattened one pixel outwards
    grown[:, 1:] |= face[:, :-1]
    grown[:, :-1] |= face[:, 1:]
    disp[grown] = POST_PX
    disp[~_near_vertical_edges(left, 6)] = np.nan
    inner = np.zeros((H, W), bool)
    inner[60:140, 100:200] = True
    config = PlanarFillConfig(ring_px=10)
    values, filled = fill_planar_regions(disp, left, config)
    assert filled[inner].all()
    assert np.allclose(values[inner], POST_PX, atol=0.1)


@pytest.mark.parametrize(
    "kw", [{"max_behind_ratio": -0.1}, {"max_behind_ratio": 1.5}, {"support_gap_px": -1}]
)
def test_bad_occlusion_config_raises(kw):
    with pytest.raises(ConfigError):
        PlanarFillConfig(**kw)
