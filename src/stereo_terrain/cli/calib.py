"""Calibration commands: ``calibrate`` (checkerboard) and ``check-calib`` (drift)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..errors import EXIT_OK, InputError
from .options import figure_path
from .outputs import all_or_none, check_output_file, progress, replace_from_temp, require_viz
from .scene import read_pair


def add_parsers(sub: Any) -> None:
    c = sub.add_parser(
        "calibrate", help="checkerboard stereo calibration -> calibration YAML + quality report"
    )
    c.add_argument("--left", required=True, help="glob of the left images, quoted: 'calib/left*.png'")
    c.add_argument(
        "--right", required=True, help="glob of the right images (paired with the left in sorted order)"
    )
    c.add_argument("--pattern", required=True, help="inner corners COLSxROWS, e.g. 9x6")
    c.add_argument("--square", type=float, required=True, help="square side in metres, e.g. 0.025")
    c.add_argument("--out", type=Path, required=True, help="calibration YAML to write")
    c.add_argument(
        "--figure", type=figure_path, help="write a figure of the coverage and per-view errors (PNG)"
    )

    k = sub.add_parser(
        "check-calib", help="how far a rig has drifted from its calibration (vertical disparity)"
    )
    k.add_argument(
        "images",
        type=Path,
        nargs="+",
        metavar="LEFT RIGHT",
        help="a raw pair; more pairs (different views) pool their matches and can confirm a yaw",
    )
    k.add_argument("--calib", type=Path, required=True)


def cmd_calibrate(args: argparse.Namespace) -> int:
    from ..calibrate import (
        MAX_EPIPOLAR_RMS_PX,
        BoardConfig,
        calibrate_from_globs,
        parse_pattern,
        quality_report,
    )
    from ..calibration import write_opencv_yaml

    cols, rows = parse_pattern(args.pattern)
    board = BoardConfig(cols, rows, args.square)
    if args.out.suffix.lower() not in (".yaml", ".yml", ".xml"):
        raise InputError(f"--out must be a .yaml, .yml or .xml file (OpenCV FileStorage), got {args.out}")
    # Fail before the detection work, not after it.
    check_output_file(args.out, "--out")
    check_output_file(args.figure, "--figure")
    if args.figure is not None:
        require_viz("--figure")

    def view_done(done: int, total: int, name: str, reason: str | None) -> None:
        progress(done, total, f"{name}: {'board found' if reason is None else 'skipped, ' + reason}")

    result = calibrate_from_globs(args.left, args.right, board, progress=view_done)
    for line in quality_report(result):
        print(line)
    if not result.quality.usable:
        raise InputError(
            f"calibration unusable: the rectified corners are {result.quality.epipolar_rms_px:.1f} px "
            f"apart vertically (RMS; good rigs give < {MAX_EPIPOLAR_RMS_PX} px), "
            f"so {args.out} was not written; "
            "use distinct views of the board moved around the image, paired left/right in the same order"
        )
    # Both outputs or neither (found in review: a figure that could not be written left the
    # calibration written before it, a half-done command): each is written to a temporary
    # name, and both are renamed onto theirs when the block ends without an error.
    with all_or_none():
        replace_from_temp(args.out, lambda tmp: write_opencv_yaml(result.calibration, tmp))
        if args.figure is not None:
            try:
                from ..viz.calibration import save_calibration_figure
            except ImportError as exc:
                raise InputError(
                    f"--figure needs matplotlib ({exc}); install with pip install 'stereo-terrain[viz]'"
                ) from None
            replace_from_temp(args.figure, lambda tmp: save_calibration_figure(result, tmp))
    print(f"wrote {args.out}")
    if args.figure is not None:
        print(f"wrote {args.figure}")
    return EXIT_OK


def cmd_check_calib(args: argparse.Namespace) -> int:
    import numpy as np

    from ..calibration import read_calibration
    from ..drift import DriftConfig, check_calibration
    from ..rectify import compute_rectification, rectify

    if len(args.images) % 2:
        raise InputError(
            f"check-calib takes pairs of images (LEFT RIGHT [LEFT RIGHT ...]), got {len(args.images)} files"
        )
    calib = read_calibration(args.calib)
    rect = compute_rectification(calib)
    pairs = [
        rectify(*read_pair(left, right, calib, args.calib), rect)
        for left, right in zip(args.images[::2], args.images[1::2], strict=True)
    ]
    cfg = DriftConfig()
    c = check_calibration(pairs, cfg)
    print(f"pairs: {c.n_pairs}, matches: {c.n_matches}")
    if c.n_matches:
        print(
            f"vertical disparity y_left - y_right: median {c.median_px:+.3f} px, spread {c.spread_px:.3f} px "
            f"(1.4826 MAD), |.| 90th percentile {c.p90_abs_px:.3f} px"
        )
    if c.rotation is not None:
        deg, se = np.degrees(c.rotation.rotvec_rad), np.degrees(c.rotation.stderr_rad)
        parts = ", ".join(
            f"{a} {d:+.3f}" + (f" (+-{s:.3f})" if np.isfinite(s) else "")
            for a, d, s in zip("xyz", deg, se, strict=True)
        )
        print(f"right camera drift to undo (deg, rectified frame; 0 = not significant): {parts}")
        if not c.yaw_confirmed:
            print(
                f"  yaw (y) held at 0: it needs {cfg.yaw_frames} pairs of different views that agree on it "
                "(one view cannot tell a yaw from a lens-distortion residual)"
            )
        print(
            f"worst error it causes over the image: vertical {c.vertical_error_px:.2f} px, "
            f"disparity {c.disparity_error_px:.2f} px"
        )
    if c.verdict == "unknown":
        print(
            f"verdict: unknown (fewer than {cfg.min_matches} matches; point the cameras at a textured "
            "scene a metre or more away)"
        )
    else:
        print(
            f"verdict: {c.verdict} (drift {c.drift_px:.2f} px; ok < {cfg.ok_px} px <= degraded < "
            f"{cfg.recalibrate_px} px <= recalibrate)"
        )
    return EXIT_OK


COMMANDS = {"calibrate": cmd_calibrate, "check-calib": cmd_check_calib}
