"""Random scene specs: geometry, cameras, textures, lighting and sensor drawn from an ``rng``.

:func:`random_scene_spec` picks the profile; each has its module:

* ``default_profile``: the scenes of version 1, unchanged;
* ``realistic_profile``: webcam photos of real stairs, and :func:`oakd_overrides`;
* ``draws``: what both draw alike (a staircase, a box, the overrides, the paint).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import InputError
from ..spec import PROFILES, SceneSpec, _check_image_size
from .default_profile import _random_default_spec
from .realistic_profile import _random_realistic_spec, oakd_overrides

__all__ = ["oakd_overrides", "random_scene_spec"]


def random_scene_spec(
    rng: np.random.Generator,
    *,
    image_size: tuple[int, int] = (640, 480),
    kind: str | None = None,
    weak_texture: bool | None = None,
    profile: str = "default",
    **overrides: Any,
) -> SceneSpec:
    """Draw a random scene (geometry, cameras, textures, lighting, sensor).

    Two profiles: ``"default"`` (the scenes below, unchanged since version 1: a camera
    pitched down 0-30 deg over a textured floor, mild lens distortion) and
    ``"realistic"``, which imitates webcam photos of real staircases (see
    :func:`_random_realistic_spec` for what it draws: level camera, side walls,
    handrails, wood and paint, strong distortion, JPEG).

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness; the same state gives the same spec.
    image_size : (width, height)
        Focal lengths scale with the width (``fx`` in ``[0.8, 0.9] * width``).
    kind : {"stairs", "box", "none"} or None
        None draws stairs (70 %), a box (20 %) or nothing (10 %); realistic profile:
        80 %, 10 %, 10 %.
    weak_texture : bool or None
        None: weakly textured with probability 0.3. Weak scenes paint the risers and stair
        (or box) sides, and with probability 0.5 the treads (box top), with a texture of
        0.5-1.5 grey levels std before noise; every other surface has a texture of at
        least 6-10 grey levels std. Realistic profile: None draws the material, True
        picks one with painted risers (all painted, or wooden treads on painted risers),
        False one without (wood or carpet throughout).
    profile : {"default", "realistic"}
        Which kind of scenes to draw (:data:`PROFILES`); recorded in ``spec.profile``.
    **overrides
        Fields of :class:`SceneSpec` or of the obstacle's spec (e.g. ``rise_m=0.2``,
        ``noise_sigma=(0, 0)``). Geometry not overridden is redrawn until the first
        riser (bottom edge: centre and +-35 % of the width) and the top tread's front
        edge are in view of the left camera.

    Notes
    -----
    Exposure is automatic: the ground's nominal grey level is drawn in [95, 150]; albedos
    are lowered where a lit face would exceed grey 200 (no saturated faces).

    Returns
    -------
    SceneSpec

    Raises
    ------
    InputError
        Unknown profile, kind or override, bad values, or overrides that keep the
        obstacle out of view.
    """
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if profile not in PROFILES:
        raise InputError(f"profile must be one of {', '.join(PROFILES)}; got {profile!r}")
    size = _check_image_size(image_size, "random_scene_spec")
    if profile == "realistic":
        return _random_realistic_spec(rng, size, kind, weak_texture, overrides)
    return _random_default_spec(rng, size, kind, weak_texture, overrides)
