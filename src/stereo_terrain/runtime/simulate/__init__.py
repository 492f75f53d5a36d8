"""A simulated approach: a trotting robot with the stereo rig walks toward a staircase.

Frames are rendered along the robot's path (:mod:`stereo_terrain.synthetic`, the robot
moving is the staircase coming closer in the body's yaw frame, with the trot's pitch
oscillation in the body attitude), run through the live loop (pipeline + swing trigger
+ terrain messages), and a kinematic foot model walks the four feet over the true step
profile with the swing heights the messages command. The same walk with the blind
nominal swing shows what the perception buys: with the paper's numbers a 0.15 m swing
hits the edge of a 0.21 m step, the raised one clears it.

Two looks (``ApproachConfig.profile``): ``"default"``, the textured staircase of the
default profile before a back wall, and ``"realistic"``, the same stairs and rig dressed
as the realistic profile's scenes (issue 11): side walls, handrails, wood or paint, a
webcam's lens, noise and JPEG, drawn from ``seed``. In both the walls and the textures
move with the stairs (``SceneSpec.texture_origin_m``), and each frame has its own sensor
noise (``SceneSpec.noise_seed``).

Foot model (sagittal plane, point feet, body at constant speed ``v``): trot, diagonal
pairs half a period apart; a swing lasts ``T/2``, lifts off where the foot stood and
touches down ``v T / 4`` ahead of its hip (Raibert's heuristic, as on the Cheetah). Along
the swing the foot first lifts (the first ``lift_fraction`` of the swing) then moves
forward on a quintic; its height follows ``z_lo + (apex - z_lo) sin(pi s)`` up to the apex
(``apex = z_lo + swing height``) and ``z_td + (apex - z_td) sin(pi s)`` down to the
touchdown height. The swing height is chosen at lift-off, as a controller does.

Layout (each module imports only those before it): ``approach`` (:class:`ApproachConfig`,
the scene at each point of the walk, the rendered frames) -> ``controller`` (the swing a
message commands, where it is raised) -> ``feet`` (the foot model) -> ``run``
(:func:`simulate_approach`, :func:`load_approach`).
"""

from .approach import (
    APPROACH_PROFILES,
    MAX_FRAMES,
    ApproachConfig,
    approach_spec,
    body_pitch,
    render_approach,
    true_x,
)
from .controller import SwingCommand, commanded_swing, trigger_position
from .feet import FootSwing, simulate_feet, step_profile
from .run import (
    ApproachResult,
    FrameSource,
    _approach_json,
    evaluate_approach,
    load_approach,
    simulate_approach,
)

__all__ = [
    "APPROACH_PROFILES",
    "MAX_FRAMES",
    "ApproachConfig",
    "ApproachResult",
    "FootSwing",
    "FrameSource",
    "SwingCommand",
    "_approach_json",
    "approach_spec",
    "body_pitch",
    "commanded_swing",
    "evaluate_approach",
    "load_approach",
    "render_approach",
    "simulate_approach",
    "simulate_feet",
    "step_profile",
    "trigger_position",
    "true_x",
]
