"""The terrain stage's entry point, :func:`build_terrain`, and its safety net for a step
too tall to climb."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import ConfigError
from ..planes.orientation import PlaneSet
from .assemble import _assemble
from .model import NONE, StairModel, TerrainConfig
from .nosings import ImageLines


def build_terrain(
    planes: PlaneSet,
    config: TerrainConfig | None = None,
    *,
    floor_known: bool | None = None,
    lines: ImageLines | None = None,
) -> StairModel:
    """Assemble a staircase, a box, or nothing from unordered planes.

    Parameters
    ----------
    planes : PlaneSet
        In a gravity-aligned frame with ``planes.up == +z``.
    config : TerrainConfig
    floor_known : bool, optional
        Whether the frame's origin is on the floor (a rig, or a floor plane found below
        the cameras). Where it is not and every horizontal plane is above the cameras,
        there is no ground to measure a first rise from and nothing is reported. None:
        taken as unknown when the cameras are less than ``min_rise_m`` above the origin
        (the origin left at the cameras).
    lines : ImageLines, optional
        The rectified left image's line segments and its camera in the planes' frame:
        steps beyond the last whose nosings they show are added
        (``TerrainConfig.nosing_steps``, :mod:`.nosings`). None: not looked for.

    Returns
    -------
    StairModel; ``obstacle == "none"`` (with a note) is a normal result.
    """
    config = config or TerrainConfig()
    if not np.allclose(planes.up, [0.0, 0.0, 1.0], atol=1e-6):
        raise ConfigError("build_terrain needs planes in a gravity-aligned frame (up = +z)")
    if floor_known is None:
        floor_known = bool(planes.camera_position[2] >= config.min_rise_m)
    model = _assemble(planes, config, floor_known=floor_known, lines=lines)
    if model.obstacle != NONE or config.max_obstacle_rise_m <= config.max_rise_m:
        return model
    # Safety net: is there a step too tall for a stair, that the robot cannot climb?
    # (A first riser inferred from a tread alone is not enough for a step too tall to be a
    # stair: that is a table top. Nor are steps continued beyond the last riser plane at
    # the median rise: the net asks for tall faces whose top is seen.)
    tall = _assemble(
        planes,
        dataclasses.replace(config, max_rise_m=config.max_obstacle_rise_m, continue_steps=False),
        tread_first=False,
        floor_known=floor_known,
    )
    if tall.obstacle == NONE or max(s.rise_m for s in tall.steps) <= config.max_rise_m:
        return model
    if any(s.rise_m > config.max_rise_m and s.tread is None for s in tall.steps):
        # A vertical face taller than a stair rise whose top is not seen is a wall or a
        # piece of furniture's front as much as a step: the net needs the top.
        return model
    note = f"a step taller than a stair rise ({config.max_rise_m:.2f} m): {tall.note}"
    return dataclasses.replace(tall, note=note)
