"""The fine up, from the extracted planes (:func:`refine_up_from_planes`, the second stage
of :mod:`stereo_terrain.gravity`)."""

from __future__ import annotations

import math

import numpy as np

from .._numeric import median
from ..planes.orientation import HORIZONTAL, VERTICAL, PlaneSet
from .config import GravityConfig, GravityEstimate, _failed

#: Scale of the Cauchy weights on a plane's normalised residual (in sigmas).
_CAUCHY_SCALE = 2.5


def _sym2_eigen(a: float, b: float, d: float) -> tuple[float, float]:
    """Largest and smallest eigenvalue of the symmetric 2x2 ``[[a, b], [b, d]]`` (the
    smallest as the determinant over the largest, which keeps its digits near singular)."""
    big = 0.5 * (a + d + math.sqrt((a - d) ** 2 + 4.0 * b * b))
    return big, ((a * d - b * b) / big if big > 0 else 0.0)


def _irls_up(
    cons: list[tuple[str, np.ndarray, np.ndarray]], u0: tuple[float, float, float], floor: float
) -> tuple[np.ndarray, float] | None:
    """The iteratively reweighted Gauss-Newton of :func:`refine_up_from_planes` on the
    sphere, in Python floats (issue 13: its 2x2 and 3-vector NumPy calls, a dozen per plane
    and step, cost about 1 ms a frame; the same arithmetic written out is a tenth of it and
    agrees to rounding). Returns up and the largest variance of its tangent covariance
    widened by the weighted chi^2 (before the structural floor), or None when the planes
    do not fix up (``H``'s condition number above 1e8)."""
    rows = []  # (horizontal?, normal, covariance's 6 unique entries)
    for kind, n, c in cons:
        cl = c.tolist()
        rows.append(
            (
                kind == HORIZONTAL,
                (float(n[0]), float(n[1]), float(n[2])),
                (cl[0][0], cl[0][1], cl[0][2], cl[1][1], cl[1][2], cl[2][2]),
            )
        )
    k = len(rows)
    weights = [1.0] * k
    chi = [0.0] * k
    u0_, u1, u2 = u0
    h00 = h01 = h11 = 0.0
    for _ in range(8):
        # The tangent basis of _tangent_basis: a = u x e_x (or u x e_y), b = u x a.
        a0, a1, a2 = 0.0, u2, -u1
        if math.sqrt(a1 * a1 + a2 * a2) < 0.5:
            a0, a1, a2 = -u2, 0.0, u0_
        na = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        a0, a1, a2 = a0 / na, a1 / na, a2 / na
        b0, b1, b2 = u1 * a2 - u2 * a1, u2 * a0 - u0_ * a2, u0_ * a1 - u1 * a0
        h00 = h01 = h11 = g0 = g1 = 0.0
        for i, (horizontal, (n0, n1, n2), (c00, c01, c02, c11, c12, c22)) in enumerate(rows):
            r_a, r_b = a0 * n0 + a1 * n1 + a2 * n2, b0 * n0 + b1 * n1 + b2 * n2  # B n
            w = weights[i]
            if horizontal:  # up = n: W = (B C B^T + floor I)^-1, residual B n, J = I
                ca0, ca1, ca2 = (
                    c00 * a0 + c01 * a1 + c02 * a2,
                    c01 * a0 + c11 * a1 + c12 * a2,
                    c02 * a0 + c12 * a1 + c22 * a2,
                )
                cb0, cb1, cb2 = (
                    c00 * b0 + c01 * b1 + c02 * b2,
                    c01 * b0 + c11 * b1 + c12 * b2,
                    c02 * b0 + c12 * b1 + c22 * b2,
                )
                m00 = a0 * ca0 + a1 * ca1 + a2 * ca2 + floor  # B C B^T + floor I
                m01 = b0 * ca0 + b1 * ca1 + b2 * ca2
                m11 = b0 * cb0 + b1 * cb1 + b2 * cb2 + floor
                det = m00 * m11 - m01 * m01
                w00, w01, w11 = m11 / det, -m01 / det, m00 / det
                wr_a, wr_b = w00 * r_a + w01 * r_b, w01 * r_a + w11 * r_b
                chi[i] = math.sqrt(max(r_a * wr_a + r_b * wr_b, 0.0) / 2.0)
                h00 += w * w00
                h01 += w * w01
                h11 += w * w11
                g0 += w * wr_a
                g1 += w * wr_b
            else:  # n . up = 0: one residual, J = (B n)^T, W = 1 / (u C u + floor)
                ucu = (
                    u0_ * (c00 * u0_ + c01 * u1 + c02 * u2)
                    + u1 * (c01 * u0_ + c11 * u1 + c12 * u2)
                    + u2 * (c02 * u0_ + c12 * u1 + c22 * u2)
                )
                w_inv = 1.0 / (ucu + floor)
                r0 = -(n0 * u0_ + n1 * u1 + n2 * u2)
                chi[i] = math.sqrt(r0 * w_inv * r0)
                s_a, s_b = w * r_a * w_inv, w * r_b * w_inv
                h00 += s_a * r_a
                h01 += s_a * r_b
                h11 += s_b * r_b
                g0 += s_a * r0
                g1 += s_b * r0
        big, small = _sym2_eigen(h00, h01, h11)
        if not small > 0 or big / small > 1e8:
            return None
        det = h00 * h11 - h01 * h01
        d0, d1 = (h11 * g0 - h01 * g1) / det, (h00 * g1 - h01 * g0) / det
        u0_, u1, u2 = u0_ + a0 * d0 + b0 * d1, u1 + a1 * d0 + b1 * d1, u2 + a2 * d0 + b2 * d1
        nu = math.sqrt(u0_ * u0_ + u1 * u1 + u2 * u2)
        u0_, u1, u2 = u0_ / nu, u1 / nu, u2 / nu
        weights = [1.0 / (1.0 + (c / _CAUCHY_SCALE) ** 2) for c in chi]
        if math.sqrt(d0 * d0 + d1 * d1) < 1e-7:
            break
    # cov = H^-1: its largest eigenvalue is 1 / H's smallest.
    var_max = 1.0 / _sym2_eigen(h00, h01, h11)[1]
    # Residual scatter beyond the model (weighted chi^2 per degree of freedom) widens sigma.
    dof = sum(1 if horizontal else 0 for horizontal, _, _ in rows) + k - 2
    sw = sum(weights)
    chi2 = sum(w * c * c for w, c in zip(weights, chi, strict=True)) / max(sw, 1e-9) * (dof + 2)
    scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    return np.array([u0_, u1, u2]), scale * var_max


def refine_up_from_planes(planes: PlaneSet, config: GravityConfig | None = None) -> GravityEstimate:
    """Fine gravity-up from extracted planes (stage 2 above), in the planes' frame.

    Each horizontal plane says ``up = n``, each vertical one ``n . up = 0``; each with the
    covariance of its normal from the scatter of its inliers (``sigma^2 / lambda`` along
    each in-plane axis, ``sigma`` the plane's RMS) plus ``structure_sigma_deg``. Solved by
    iteratively reweighted Gauss-Newton on the sphere from ``planes.up``, with Cauchy
    weights on each plane's normalised residual: a plane fitted across two surfaces (its
    normal several degrees off) loses its say instead of tilting everything.

    Returns
    -------
    GravityEstimate in ``planes.frame``; ``ok`` False when the planes do not fix up (fewer
    than two independent constraints).
    """
    config = config or GravityConfig()
    frame = planes.frame
    u = np.asarray(planes.up, dtype=np.float64)
    u = u / np.linalg.norm(u)
    P = planes.samples.points.astype(np.float64)
    depth_sigma = planes.samples.sigma_m
    floor = math.radians(config.structure_sigma_deg) ** 2
    # Inliers per independent one (correlated disparity errors, see GravityConfig).
    per_independent = max(1.0, (config.correlation_px / max(planes.samples.stride_px, 1)) ** 2)
    cons: list[tuple[str, np.ndarray, np.ndarray]] = []  # (kind, normal, normal covariance)
    n_h = n_v = 0
    total = max(len(P), 1)
    for seg in planes.segments:
        if seg.kind not in (HORIZONTAL, VERTICAL) or seg.count < 10:
            continue
        q = P[seg.indices]
        q = q - q.mean(axis=0)
        lam, E = np.linalg.eigh(q.T @ q)
        sig = depth_sigma[seg.indices]
        # np.median's bits where nothing is NaN (nanmedian's own path then; _numeric.median
        # at a fifth of np.median's time)
        noise = float(np.nanmedian(sig) if np.isnan(sig).any() else median(sig))
        sigma2 = max(seg.rms_m, noise, 1e-3) ** 2
        inflate = min(per_independent, seg.count / 3.0) if seg.count > 3 else 1.0
        inflate = max(inflate, seg.count / config.plane_pieces)
        cov_n = inflate * sigma2 * sum(np.outer(E[:, k], E[:, k]) / max(lam[k], 1e-9) for k in (1, 2))
        n = seg.plane.normal if seg.kind == VERTICAL or seg.plane.normal @ u >= 0 else -seg.plane.normal
        cons.append((seg.kind, n, cov_n))
        n_h += seg.count if seg.kind == HORIZONTAL else 0
        n_v += seg.count if seg.kind == VERTICAL else 0
    h_frac, v_frac = n_h / total, n_v / total
    if sum(2 if kind == HORIZONTAL else 1 for kind, _, _ in cons) < 2:  # up has 2 degrees of freedom
        return _failed(frame, "too few planes to fix up", h_frac, v_frac)
    solved = _irls_up(cons, (float(u[0]), float(u[1]), float(u[2])), floor)
    if solved is None:
        return _failed(
            frame,
            "the planes do not fix up (need a horizontal plane or two wall directions)",
            h_frac,
            v_frac,
        )
    u, var_max = solved
    sigma = math.degrees(math.sqrt(var_max + floor))
    ok = sigma <= config.max_sigma_deg
    why = "planes of the scene" if ok else f"the planes fix up only to {sigma:.1f} deg"
    return GravityEstimate(u, frame, sigma, ok, h_frac, v_frac, why)
