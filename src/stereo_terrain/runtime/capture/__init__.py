"""Stereo capture: two cameras, two video files or a folder of recorded pairs.

Every source gives :class:`CaptureEvent` values from :meth:`read`: a timestamped
:class:`StereoFrame`, or ``none`` (no new pair yet), ``unreadable`` (a frame could not be
decoded) or ``end``. Sources never queue: a live source hands out the *newest* pair and
counts the frames it skipped, so the loop never works on stale images.

:class:`Capture` wraps a source and drops pairs whose left/right timestamps differ by
more than ``max_skew_s``: the paper (section 5) notes that a lag between the two frames
acts like a moved camera, i.e. a wrong extrinsic calibration, while the robot moves.

The recorded-pairs folder (written by :func:`record_pairs`, read by :class:`FolderPairs`)::

    DIR/pairs.csv             index,t_left,t_right,left,right[,x,y,z,roll,pitch,yaw]
    DIR/left_000000.png ...   raw (unrectified) grey images
    DIR/calib.yaml, rig.yaml  optional: used by ``replay`` when --calib/--rig are not given

Times are seconds; the optional pose columns are the body's odometry (world frame,
metres) and attitude (radians) at the pair's time, as a state estimator would give them.

The package's parts: ``events.py`` (what a source gives, the skew check), ``pacing.py``
(recorded sources against a clock), ``cameras.py`` (live cameras, two video files),
``folder.py`` (the recorded-pairs folder) and ``writing.py`` (recording).
"""

from .cameras import CameraPair, VideoPair, open_devices, parse_device
from .events import (
    END,
    FRAME,
    NONE,
    SKEW,
    UNREADABLE,
    Capture,
    CaptureEvent,
    CaptureStats,
    Clock,
    PairSource,
    StereoFrame,
)
from .folder import MAX_ABS_TIME_S, MAX_REPLAY_GAP_S, PAIRS_FILE, POSE_KEYS, FolderPairs, read_pairs_index
from .pacing import Paced, match_stamps, replay_step_s
from .writing import PairWriter, record_pairs, write_pairs

__all__ = [
    "END",
    "FRAME",
    "MAX_ABS_TIME_S",
    "MAX_REPLAY_GAP_S",
    "NONE",
    "PAIRS_FILE",
    "POSE_KEYS",
    "SKEW",
    "UNREADABLE",
    "CameraPair",
    "Capture",
    "CaptureEvent",
    "CaptureStats",
    "Clock",
    "FolderPairs",
    "Paced",
    "PairSource",
    "PairWriter",
    "StereoFrame",
    "VideoPair",
    "match_stamps",
    "open_devices",
    "parse_device",
    "read_pairs_index",
    "record_pairs",
    "replay_step_s",
    "write_pairs",
]
