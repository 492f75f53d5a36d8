"""Rendered checkerboard views seen by a known stereo rig (ground truth for calibration tests)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

SIZE = (640, 480)
SQUARE_M = 0.03
PATTERN = (9, 6)  # inner corners
K_LEFT = np.array([[600.0, 0, 322.0], [0, 601.0, 238.0], [0, 0, 1]])
D_LEFT = np.array([-0.18, 0.05, 0.0005, -0.0003, 0.0])
K_RIGHT = np.array([[605.0, 0, 318.0], [0, 605.5, 243.0], [0, 0, 1]])
D_RIGHT = np.array([-0.15, 0.03, -0.0002, 0.0004, 0.0])
R_RIGHT = cv2.Rodrigues(np.radians([0.4, -0.6, 0.3]).reshape(3, 1))[0]
T_RIGHT = np.array([-0.09, 0.0008, 0.0012])


def _rays(K, D, supersample):
    """Undistorted rays (x, y, 1) of every sub-pixel sample, (S*S, H*W, 3); pose-independent."""
    w, h = SIZE
    offs = (np.arange(supersample) + 0.5) / supersample - 0.5
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 1e-9)
    out = []
    for du in offs:
        for dv in offs:
            px = np.column_stack([(u + du).ravel(), (v + dv).ravel()]).reshape(-1, 1, 2)
            xy = cv2.undistortPoints(px, K, D, criteria=criteria).reshape(-1, 2)
            out.append(np.column_stack([xy, np.ones(len(xy))]))
    return np.stack(out)


def _view(rays, R_cb, t_cb, rng):
    """Grey image of the board (plane z = 0 of the board frame, ``X_cam = R_cb X_board + t_cb``)."""
    w, h = SIZE
    acc = np.zeros(h * w)
    n = R_cb[:, 2]
    for d in rays:
        s = (n @ t_cb) / (d @ n)
        board = (s[:, None] * d - t_cb) @ R_cb  # R_cb^T (p - t)
        bx, by = board[:, 0] / SQUARE_M, board[:, 1] / SQUARE_M
        inside = (bx > -1) & (bx < PATTERN[0]) & (by > -1) & (by < PATTERN[1]) & (s > 0)
        margin = (bx > -1.6) & (bx < PATTERN[0] + 0.6) & (by > -1.6) & (by < PATTERN[1] + 0.6) & (s > 0)
        black = (np.floor(bx) + np.floor(by)) % 2 == 0
        grey = np.where(margin, 235.0, 110.0)
        acc += np.where(inside & black, 25.0, grey)
    img = (acc / len(rays)).reshape(h, w) + rng.normal(0.0, 1.5, (h, w))
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def write_board_views(out: Path, count: int = 10, seed: int = 0) -> None:
    """``count`` pairs ``left_NN.png`` / ``right_NN.png`` of the board in random poses."""
    rng = np.random.default_rng(seed)
    rays_l, rays_r = _rays(K_LEFT, D_LEFT, 2), _rays(K_RIGHT, D_RIGHT, 2)
    centre = np.array([(PATTERN[0] - 1) / 2, (PATTERN[1] - 1) / 2, 0.0]) * SQUARE_M
    for i in range(count):
        R_cb = cv2.Rodrigues(np.radians(rng.uniform([-30, -30, -15], [30, 30, 15])).reshape(3, 1))[0]
        target = np.array([rng.uniform(-0.12, 0.12), rng.uniform(-0.08, 0.08), rng.uniform(0.55, 0.8)])
        t_cb = target - R_cb @ centre
        left = _view(rays_l, R_cb, t_cb, rng)
        right = _view(rays_r, R_RIGHT @ R_cb, R_RIGHT @ t_cb + T_RIGHT, rng)
        cv2.imwrite(str(out / f"left_{i:02d}.png"), left)
        cv2.imwrite(str(out / f"right_{i:02d}.png"), right)
