"""The drift model: a small rotation of the rectified right camera, fitted to the matches'
vertical disparities (:func:`estimate_right_rotation`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..rectify import Rectification
from .config import MAD_TO_SIGMA
from .matches import FeatureMatches


def _rect_intrinsics(rect: Rectification) -> tuple[float, float, float, float]:
    """``f, cx_left, cx_right, cy`` of the rectified pair, pixels."""
    return rect.focal_px, rect.cx, rect.cx + rect.doffs_px, rect.cy


def rays_from_matches(matches: FeatureMatches, rect: Rectification) -> tuple[np.ndarray, np.ndarray]:
    """Matches of ``rect``'s images -> rays of the *calibration's* rectified cameras.

    Returns
    -------
    left, right : (N, 3) float64
        ``(x, y, 1)`` rays of the rectified left camera and of the uncorrected rectified
        right camera (``rect.right_correction`` taken out), so that matches gathered under
        different corrections can be pooled.
    """
    f, cxl, cxr, cy = _rect_intrinsics(rect)
    n = len(matches)
    left = np.column_stack([(matches.left[:, 0] - cxl) / f, (matches.left[:, 1] - cy) / f, np.ones(n)])
    right = np.column_stack([(matches.right[:, 0] - cxr) / f, (matches.right[:, 1] - cy) / f, np.ones(n)])
    if rect.right_correction is not None:
        right = right @ rect.right_correction  # C^T r for each row r
        right /= right[:, 2:3]
    return left, right


def _rotate(rotvec: np.ndarray, rays: np.ndarray) -> np.ndarray:
    R, _ = cv2.Rodrigues(np.asarray(rotvec, dtype=np.float64).reshape(3, 1))
    return rays @ R.T


def vertical_residuals_px(
    rotvec: np.ndarray, left: np.ndarray, right: np.ndarray, focal_px: float
) -> np.ndarray:
    """(N,) float64: ``y_right - y_left`` in pixels after rotating the right rays by ``rotvec``."""
    q = _rotate(rotvec, right)
    return focal_px * (q[:, 1] / q[:, 2] - left[:, 1] / left[:, 2])


@dataclass(frozen=True)
class RightRotation:
    """The rotation of the rectified right camera that best removes vertical disparity.

    Attributes
    ----------
    rotvec_rad : (3,) float64
        Rodrigues vector of the correction, rectified right camera frame (x along the
        baseline, y down, z forward): ``right_correction = Rodrigues(rotvec_rad)``.
        Zero where a component was not significant.
    stderr_rad : (3,) float64
        Standard errors of the components (inf where not estimated).
    n_matches, n_inliers : int
    sigma_px : float
        Robust noise of the vertical disparity after the correction, pixels.
    rms_before_px, rms_after_px : float
        RMS vertical disparity of the inliers without and with the correction, pixels.
    significance : float
        Chi-square of the improvement, ``(SS_before - SS_after) / sigma^2``.
    """

    rotvec_rad: np.ndarray = field(repr=False)
    stderr_rad: np.ndarray = field(repr=False)
    n_matches: int
    n_inliers: int
    sigma_px: float
    rms_before_px: float
    rms_after_px: float
    significance: float

    @property
    def angle_deg(self) -> float:
        return math.degrees(float(np.linalg.norm(self.rotvec_rad)))


def estimate_right_rotation(
    left: np.ndarray,
    right: np.ndarray,
    focal_px: float,
    *,
    component_sigma: float = 3.0,
    estimate: tuple[bool, bool, bool] = (True, True, True),
) -> RightRotation | None:
    """Fit the rotation of the right rays that zeroes the vertical disparity.

    Parameters
    ----------
    left, right : (N, 3) float64
        Matched rays of the rectified left and (uncorrected) right cameras, see
        :func:`rays_from_matches`.
    focal_px : float
        Rectified focal length; residuals are measured in pixels.
    component_sigma : float
        Components smaller than this many standard errors are fixed at zero and the rest
        refitted (a weakly observed yaw must not add noise to depth).
    estimate : (3,) bool
        Which components (x, y, z) to estimate; the others are held at zero.

    Returns
    -------
    RightRotation, or None with fewer than 10 matches.

    Notes
    -----
    Robust: a Cauchy-weighted Gauss-Newton fit (scale 0.5 px) finds the inliers (within 4
    sigma and 1 px of the fit), then a plain least-squares fit on them gives the estimate
    and its covariance. Three parameters and an analytic Jacobian: about a millisecond for
    a few thousand matches.
    """
    n = len(left)
    if n < 10:
        return None
    free = np.array(estimate, dtype=bool)

    def fit(mask: np.ndarray, rows: np.ndarray, cauchy_px: float | None) -> np.ndarray:
        return _gauss_newton(left[rows], right[rows], focal_px, mask, cauchy_px)

    everyone = np.ones(n, dtype=bool)
    w = fit(free, everyone, 0.5) if free.any() else np.zeros(3)
    r = vertical_residuals_px(w, left, right, focal_px)
    sigma = max(MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r)))), 0.02)
    inl = np.abs(r) <= max(4.0 * sigma, 1.0)
    if inl.sum() < 10:
        return None
    stderr = np.full(3, np.inf)
    for _ in range(3):  # drop insignificant components, refit
        if not free.any():
            w = np.zeros(3)
            break
        w = fit(free, inl, None)
        r_in = vertical_residuals_px(w, left[inl], right[inl], focal_px)
        sigma = max(float(np.sqrt(np.mean(r_in**2))), 0.02)
        J = _jacobian(w, left[inl], right[inl], focal_px)[:, free]
        try:
            cov = sigma**2 * np.linalg.inv(J.T @ J)
        except np.linalg.LinAlgError:
            cov = np.full((int(free.sum()),) * 2, np.inf)
        stderr = np.full(3, np.inf)
        stderr[free] = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        weak = free & ~(np.abs(w) > component_sigma * stderr)
        if not weak.any():
            break
        free &= ~weak
        w[weak] = 0.0
    if not free.any():
        w = np.zeros(3)
    r0 = vertical_residuals_px(np.zeros(3), left[inl], right[inl], focal_px)
    r1 = vertical_residuals_px(w, left[inl], right[inl], focal_px)
    ss0, ss1 = float(np.sum(r0**2)), float(np.sum(r1**2))
    sigma = max(float(np.sqrt(ss1 / max(int(inl.sum()) - int(free.sum()), 1))), 0.02)
    return RightRotation(
        w,
        stderr,
        n,
        int(inl.sum()),
        sigma,
        float(np.sqrt(ss0 / inl.sum())),
        float(np.sqrt(ss1 / inl.sum())),
        (ss0 - ss1) / sigma**2,
    )


def _jacobian(w: np.ndarray, left: np.ndarray, right: np.ndarray, focal_px: float) -> np.ndarray:
    """(N, 3) Jacobian of :func:`vertical_residuals_px` w.r.t. a small extra rotation.

    With ``q = R(w) r`` and an extra rotation ``d``, ``q' = q + d x q``, so
    ``d(q_y / q_z) / dd = (-(1 + y^2), x y, x)`` with ``x, y = q_x / q_z, q_y / q_z`` (the
    tilt, yaw and roll signatures of the module docstring).
    """
    del left  # the residual's left term does not depend on the rotation
    q = _rotate(w, right)
    x, y = q[:, 0] / q[:, 2], q[:, 1] / q[:, 2]
    return focal_px * np.column_stack([-(1.0 + y * y), x * y, x])


def _gauss_newton(
    left: np.ndarray,
    right: np.ndarray,
    focal_px: float,
    free: np.ndarray,
    cauchy_px: float | None,
    iterations: int = 30,
) -> np.ndarray:
    """(3,) rotation vector minimising the (Cauchy-weighted) vertical residuals; components
    not in ``free`` stay zero."""
    w = np.zeros(3)
    for _ in range(iterations):
        r = vertical_residuals_px(w, left, right, focal_px)
        J = _jacobian(w, left, right, focal_px)[:, free]
        wt = np.ones_like(r) if cauchy_px is None else 1.0 / (1.0 + (r / cauchy_px) ** 2)
        A = J.T @ (J * wt[:, None])
        try:
            step = np.linalg.solve(A, -(J.T @ (wt * r)))
        except np.linalg.LinAlgError:
            break
        w[free] += step
        if np.max(np.abs(step)) < 1e-10:
            break
    return w


def rotation_effect_px(rotvec: np.ndarray, rect: Rectification, *, grid: int = 9) -> tuple[float, float]:
    """Worst vertical and horizontal displacement a right-camera rotation causes, pixels.

    The rotation moves every rectified right pixel; its vertical part is epipolar error,
    its horizontal part a disparity error (depth bias). Evaluated on a ``grid x grid``
    lattice over the image for points far away.
    """
    f, _, cxr, cy = _rect_intrinsics(rect)
    w, h = rect.image_size
    u, v = np.meshgrid(np.linspace(0, w - 1, grid), np.linspace(0, h - 1, grid))
    rays = np.column_stack([(u.ravel() - cxr) / f, (v.ravel() - cy) / f, np.ones(u.size)])
    q = _rotate(np.asarray(rotvec, dtype=np.float64), rays)
    dx = f * (q[:, 0] / q[:, 2] - rays[:, 0])
    dy = f * (q[:, 1] / q[:, 2] - rays[:, 1])
    return float(np.max(np.abs(dy))), float(np.max(np.abs(dx)))
