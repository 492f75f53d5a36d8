"""Sub-pixel feature matches of a rectified pair (ORB, then Lucas-Kanade), whose vertical
disparities measure the drift."""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from ..rectify import RectifiedPair
from .config import DriftConfig


@dataclass(frozen=True)
class FeatureMatches:
    """Sub-pixel feature matches of a rectified pair.

    Attributes
    ----------
    left, right : (N, 2) float64, pixels of the rectified left / right image
    """

    left: np.ndarray = field(repr=False)
    right: np.ndarray = field(repr=False)

    def __len__(self) -> int:
        return len(self.left)

    @property
    def vertical_px(self) -> np.ndarray:
        """(N,) float64: vertical disparity ``y_left - y_right``, pixels (0 when rectified)."""
        return self.left[:, 1] - self.right[:, 1]


def match_features(pair: RectifiedPair, config: DriftConfig | None = None) -> FeatureMatches:
    """ORB matches between the rectified images, refined to sub-pixel by Lucas-Kanade.

    A match must lie within ``search_rows_px`` rows, have a disparity between
    ``-search_rows_px`` and half the image width, pass Lowe's ratio test among the
    candidates there, and survive a forward-backward Lucas-Kanade check.
    """
    cfg = config or DriftConfig()
    left, right = pair.left, pair.right
    orb = cv2.ORB_create(nfeatures=cfg.max_features)  # type: ignore[attr-defined]
    rect = pair.rectification
    kl, dl = orb.detectAndCompute(left, _feature_mask(rect.valid_left))
    kr, dr = orb.detectAndCompute(right, _feature_mask(rect.valid_right))
    empty = FeatureMatches(np.zeros((0, 2)), np.zeros((0, 2)))
    if dl is None or dr is None or len(kl) < 2 or len(kr) < 2:
        return empty
    # Candidates only where a rectified match can be: within the band of rows and a
    # plausible disparity. The ratio test then compares candidates of that region (3x
    # faster than matching everything with everything, and a repeated pattern elsewhere
    # in the image cannot veto a good match).
    w = left.shape[1]
    xyl = np.array([k.pt for k in kl], dtype=np.float32)
    xyr = np.array([k.pt for k in kr], dtype=np.float32)
    disp = xyl[:, None, 0] - xyr[None, :, 0]
    band = (
        (np.abs(xyl[:, None, 1] - xyr[None, :, 1]) <= cfg.search_rows_px)
        & (disp >= -cfg.search_rows_px)
        & (disp <= w / 2)
    )
    matcher = cv2.BFMatcher(cv2.NORM_HAMMING)
    knn = matcher.knnMatch(dl, dr, k=2, mask=band.astype(np.uint8))
    # Mutual best within the region too: a repeated pattern (a checkerboard's corners)
    # offers many look-alikes in the same rows.
    back = {
        m[0].queryIdx: m[0].trainIdx for m in matcher.knnMatch(dr, dl, k=1, mask=band.T.astype(np.uint8)) if m
    }
    pairs = [
        m[0]
        for m in knn
        if len(m) == 2
        and m[0].distance < cfg.ratio * m[1].distance
        and back.get(m[0].trainIdx) == m[0].queryIdx
    ]
    if not pairs:
        return empty
    pl = xyl[[m.queryIdx for m in pairs]]
    pr = xyr[[m.trainIdx for m in pairs]]
    pr_fine, st_f = _lucas_kanade(left, right, pl, pr, cfg.lk_window_px)
    pl_back, st_b = _lucas_kanade(right, left, pr_fine, pl, cfg.lk_window_px)
    ok = (
        (st_f == 1)
        & (st_b == 1)
        & (np.linalg.norm(pl_back - pl, axis=1) <= cfg.fb_tolerance_px)
        & (np.linalg.norm(pr_fine - pr, axis=1) <= 3.0)  # LK may not wander off the ORB match
    )
    h = left.shape[0]
    inside = (pr_fine[:, 0] >= 0) & (pr_fine[:, 0] <= w - 1) & (pr_fine[:, 1] >= 0) & (pr_fine[:, 1] <= h - 1)
    ok &= inside
    return FeatureMatches(pl[ok].astype(np.float64), pr_fine[ok].astype(np.float64))


def _feature_mask(valid: np.ndarray | None) -> np.ndarray | None:
    """Where ORB may put a feature: pixels whose 31-px descriptor patch and LK window stay
    off the sourceless border of the rectified image (None: anywhere)."""
    if valid is None:
        return None
    k = np.ones((33, 33), np.uint8)
    return cv2.erode(valid.astype(np.uint8), k, borderType=cv2.BORDER_REPLICATE) * np.uint8(255)


def _lucas_kanade(
    a: np.ndarray, b: np.ndarray, pa: np.ndarray, pb_guess: np.ndarray, window_px: int
) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel positions in ``b`` of the points ``pa`` of ``a`` from the guesses ``pb_guess``.

    Returns ``(pb (N, 2) float32, status (N,) uint8)``.
    """
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.005)
    pb, status, _ = cv2.calcOpticalFlowPyrLK(
        a,
        b,
        pa,
        pb_guess.copy(),
        winSize=(window_px, window_px),
        maxLevel=1,
        criteria=criteria,
        flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
    )
    return np.asarray(pb, dtype=np.float32).reshape(-1, 2), np.asarray(status).ravel()
