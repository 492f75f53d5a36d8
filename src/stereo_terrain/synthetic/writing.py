"""Scenes to files: one scene folder, or many random scenes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..calibration import write_opencv_yaml
from ..errors import InputError
from ..frames import save_rig
from ..rectify import write_image
from .random_scenes import random_scene_spec
from .render import SyntheticScene, render_scene
from .spec import PROFILES, _check_int


def write_scene(scene: SyntheticScene, out_dir: str | Path) -> Path:
    """Write a scene as files readable by the rest of the package.

    ``left.png``, ``right.png`` (raw grey), ``calib.yaml`` (OpenCV FileStorage, see
    :func:`~stereo_terrain.calibration.write_opencv_yaml`), ``rig.yaml``
    (:func:`~stereo_terrain.frames.save_rig`), ``truth.json`` (the truth dict) and
    ``depth_left.npy`` ((H, W) float32 metres, NaN where nothing is hit).

    Returns
    -------
    Path
        ``out_dir`` (created if missing).
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create scene directory {out}: {exc.strerror}") from None
    for name, img in (("left.png", scene.left), ("right.png", scene.right)):
        write_image(out / name, img)
    write_opencv_yaml(scene.calibration, out / "calib.yaml")
    save_rig(scene.rig, out / "rig.yaml")
    (out / "truth.json").write_text(json.dumps(scene.truth, indent=2) + "\n")
    np.save(out / "depth_left.npy", np.asarray(scene.depth_left, dtype=np.float32))
    return out


def render_scenes(
    out_dir: str | Path, count: int, seed: int, *, profile: str = "default", **kw: Any
) -> list[Path]:
    """Render ``count`` random scenes into ``out_dir/scene_000``, ``scene_001``, ...

    Deterministic: the same ``seed``, ``profile`` ("default" or "realistic", see
    :func:`random_scene_spec`) and ``kw`` (passed to :func:`random_scene_spec`) write the
    same files.
    """
    count = _check_int("render_scenes", "count", count, 0, 100_000)
    seed = _check_int("render_scenes", "seed", seed, 0, 2**63 - 1)
    if profile not in PROFILES:
        raise InputError(f"profile must be one of {', '.join(PROFILES)}; got {profile!r}")
    rng = np.random.default_rng(seed)
    paths = []
    for i in range(count):
        spec = random_scene_spec(rng, profile=profile, **kw)
        paths.append(write_scene(render_scene(spec), Path(out_dir) / f"scene_{i:03d}"))
    return paths
