"""The rendered scene of a camera close to stairs and level with them, as webcams on a
legged robot see them: the first riser's foot near or below the image's bottom edge."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from stereo_terrain.synthetic import SceneSpec, default_scene_spec


def close_level_stairs_spec(
    *,
    n_steps: int,
    width_m: float,
    distance_m: float,
    yaw_deg: float = 0.0,
    pitch_deg: float = 0.0,
    roll_deg: float = 0.0,
    **spec_over: Any,
) -> SceneSpec:
    """The default scene with its staircase straight ahead (``lateral_m`` 0) ``distance_m``
    away, seen by a camera 0.45 m high pitched down ``pitch_deg`` and rolled ``roll_deg``;
    ``spec_over`` replaces further SceneSpec fields (e.g. ``back_wall_m=None``)."""
    base = default_scene_spec()
    stairs = dataclasses.replace(
        base.obstacle,
        n_steps=n_steps,
        yaw_rad=math.radians(yaw_deg),
        lateral_m=0.0,
        width_m=width_m,
        distance_m=distance_m,
    )
    return dataclasses.replace(
        base,
        obstacle=stairs,
        camera_height_m=0.45,
        pitch_down_rad=math.radians(pitch_deg),
        body_rpy=(math.radians(roll_deg), 0.0, 0.0),
        **spec_over,
    )
