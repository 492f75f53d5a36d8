"""A live 3D view of the pipeline in Rerun (``--view``), or a saved recording (``--view-save``).

Needs the ``view`` extra (``pip install 'stereo-terrain[view]'``: ``rerun-sdk``), imported
when a :class:`RerunView` is made. Per processed pair, on the ``capture_time`` timeline
(the pair's capture time, as in the MCAP output) and the ``pair`` sequence:

- ``world/yaw``: the gravity-aligned frame (placed by the odometry when known), holding
  ``cloud`` (the grid-sampled cloud coloured by plane, labels ``plane k (kind)``),
  ``polytope/faces`` (a mesh of the risers and treads), ``polytope/edges`` and
  ``polytope/dimensions`` (rise and run of each step at its riser);
- ``world/yaw/body`` (the robot frame, with its axes) and ``.../camera_rect``, the rectified
  left camera (a pinhole, so the images sit in the 3D view) with ``image`` (the rectified
  left image), ``image/planes`` (the plane inliers as a segmentation overlay) and
  ``disparity`` (a colour-mapped depth image of the disparity, px);
- ``swing/height_m``, ``swing/trigger_distance_m``, ``swing/raise`` and
  ``steps/first_distance_m``: the swing plan and the nearest riser over time.

A saved recording is written to a temporary file and renamed at :meth:`RerunView.close`.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..ros.messages import PALETTE, frame_transforms, plane_labels, step_label

APP_ID = "stereo_terrain"


class RerunView:
    """Logs results to a Rerun viewer (spawned) or to a ``.rrd`` file.

    Parameters
    ----------
    save : path-like or None
        Write a recording here instead of opening a viewer.
    body_rpy : callable() -> (3,) or None, optional
        The body attitude the pipeline used (the rig's); None without a rig.
    epoch_offset_s : float
        Added to the loop's clock to give epoch seconds for sources without stamps.
    """

    def __init__(self, save: str | Path | None = None, *, body_rpy: Any = None, epoch_offset_s: float = 0.0):
        import rerun as rr

        self.rr = rr
        self.body_rpy = body_rpy or (lambda: None)
        self.epoch_offset_s = float(epoch_offset_s)
        self.rec = rr.RecordingStream(APP_ID)
        self.target = None if save is None else Path(save)
        self._tmp: Path | None = None
        if self.target is not None:
            fd, tmp = tempfile.mkstemp(prefix=f".{self.target.name}.", suffix=".rrd", dir=self.target.parent)
            os.close(fd)
            self._tmp = Path(tmp)
            self.rec.save(self._tmp)
        else:
            self._spawn()
        self.pairs = 0
        self._static()

    def _spawn(self) -> None:
        """Start a viewer: the ``rerun`` on PATH, else the one installed beside this Python
        (a venv's ``bin/``, which is not on PATH when the venv is not activated)."""
        import shutil
        import sys

        from ..errors import InputError

        exe = shutil.which("rerun") or str(Path(sys.executable).parent / "rerun")
        try:
            self.rr.spawn(executable_path=exe if Path(exe).is_file() else None, recording=self.rec)
        except Exception as exc:  # no viewer binary, no display, ...
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InputError(
                f"--view cannot start the Rerun viewer ({first[:160]}); use --view-save OUT.rrd and "
                "open that with 'rerun OUT.rrd'"
            ) from None

    def _static(self) -> None:
        rr, rec = self.rr, self.rec
        rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        classes = [rr.AnnotationInfo(id=0, label="none", color=(0, 0, 0, 0))] + [
            rr.AnnotationInfo(id=k + 1, label=f"plane {k}", color=tuple(int(c) for c in PALETTE[k]))
            for k in range(len(PALETTE))
        ]
        rec.log("world", rr.AnnotationContext(classes), static=True)
        rec.log(
            "world/yaw/body/axes",
            rr.Arrows3D(
                vectors=[[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.3]],
                colors=[[255, 0, 0], [0, 255, 0], [0, 0, 255]],
                labels=["x forward", "y left", "z up"],
            ),
            static=True,
        )
        for name, colour in (("height_m", (255, 200, 0)), ("trigger_distance_m", (0, 160, 255))):
            rec.log(f"swing/{name}", rr.SeriesLines(colors=[colour], names=[name]), static=True)

    def _time(self, stamp_ns: int, index: int) -> None:
        self.rec.set_time("capture_time", timestamp=np.datetime64(int(stamp_ns), "ns"))
        self.rec.set_time("pair", sequence=int(index))

    # ----------------------------------------------------------------- the loop's hooks

    def publish(self, msg: Any) -> None:
        """A terrain message (``terrain_t``): the swing plan over time."""
        rr = self.rr
        self._time(int(msg.utime) * 1000, max(0, int(msg.frame_index)))
        self.rec.log("swing/height_m", rr.Scalars([float(msg.swing_height_m)]))
        if np.isfinite(msg.trigger_distance_m):
            self.rec.log("swing/trigger_distance_m", rr.Scalars([float(msg.trigger_distance_m)]))
        self.rec.log("swing/raise", rr.Scalars([1.0 if msg.raise_swing else 0.0]))

    def on_result(self, frame: Any, result: Any) -> None:
        stamp_s = frame.stamp_s if frame.stamp_s is not None else frame.t_capture_s + self.epoch_offset_s
        self.log_result(result, int(round(stamp_s * 1e9)), frame.index, odometry=frame.odometry)

    def log_result(self, result: Any, stamp_ns: int, index: int = 0, *, odometry: Any = None) -> None:
        """Log one ``TerrainResult``."""
        rr, rec = self.rr, self.rec
        self._time(stamp_ns, index)
        if odometry is not None:
            c, s = np.cos(odometry.yaw_rad), np.sin(odometry.yaw_rad)
            rec.log(
                "world/yaw",
                rr.Transform3D(translation=odometry.position_m, mat3x3=[[c, -s, 0], [s, c, 0], [0, 0, 1]]),
            )
        T_yaw_body, T_body_camera, T_camera_rect = frame_transforms(result, self.body_rpy())
        for path, T in (
            ("world/yaw/body", T_yaw_body),
            ("world/yaw/body/camera", T_body_camera),
            ("world/yaw/body/camera/camera_rect", T_camera_rect),
        ):
            rec.log(path, rr.Transform3D(translation=T.translation, mat3x3=T.rotation))
        cam = "world/yaw/body/camera/camera_rect"
        rect = result.rectified.rectification
        w, h = rect.image_size
        rec.log(
            cam,
            rr.Pinhole(
                focal_length=rect.focal_px,
                principal_point=[rect.cx, rect.cy],
                width=w,
                height=h,
                image_plane_distance=0.5,
            ),
        )
        rec.log(f"{cam}/image", rr.Image(result.rectified.left))
        rec.log(f"{cam}/image/planes", rr.SegmentationImage(self._plane_image(result, (h, w)), opacity=0.5))
        disp = np.nan_to_num(result.disparity.disparity, nan=0.0).astype(np.float32)
        rec.log(f"{cam}/disparity", rr.DepthImage(disp, meter=1.0, colormap="turbo"))
        # The cloud and the polytope, in the yaw frame.
        planes = result.planes
        labels = plane_labels(planes)
        kinds = [seg.kind for seg in planes.segments]
        rec.log(
            "world/yaw/cloud",
            rr.Points3D(
                np.asarray(planes.samples.points, dtype=np.float32), class_ids=labels + 1, radii=0.008
            ),
        )
        rec.log(
            "world/yaw/cloud",
            rr.TextDocument("\n".join(f"plane {k}: {kind}" for k, kind in enumerate(kinds)) or "no planes"),
        )
        self._log_polytope(result)
        t = result.terrain
        if t.steps:
            rec.log("steps/first_distance_m", rr.Scalars([float(t.steps[0].distance_m)]))
        self.pairs += 1

    def _plane_image(self, result: Any, shape: tuple[int, int]) -> np.ndarray:
        """(H, W) uint8: plane k + 1 on a square of one grid cell around each inlier sample
        (where two squares meet, the higher label)."""
        import cv2

        out = np.zeros(shape, dtype=np.uint8)
        samples = result.planes.samples
        labels = plane_labels(result.planes)
        has = labels >= 0
        out[samples.rows[has], samples.cols[has]] = (labels[has] % 255 + 1).astype(np.uint8)
        size = 2 * max(1, int(samples.stride_px) // 2) + 1
        return cv2.dilate(out, np.ones((size, size), dtype=np.uint8))

    def _log_polytope(self, result: Any) -> None:
        rr, rec = self.rr, self.rec
        poly = result.terrain.polytope
        verts = np.asarray(poly.vertices, dtype=np.float32).reshape(-1, 3)
        faces = [f for f in poly.faces if len(f) >= 3]
        if not faces:
            for path in (
                "world/yaw/polytope/faces",
                "world/yaw/polytope/edges",
                "world/yaw/polytope/dimensions",
            ):
                rec.log(path, rr.Clear(recursive=False))
            return
        tris = [(f[0], f[k], f[k + 1]) for f in faces for k in range(1, len(f) - 1)]
        rec.log(
            "world/yaw/polytope/faces",
            rr.Mesh3D(
                vertex_positions=verts,
                triangle_indices=np.asarray(tris, dtype=np.uint32),
                albedo_factor=[0.2, 0.6, 1.0, 0.5],
            ),
        )
        strips = [[verts[i] for i in (*f, f[0])] for f in faces]
        rec.log("world/yaw/polytope/edges", rr.LineStrips3D(strips, colors=[20, 20, 20], radii=0.005))
        steps = result.terrain.steps
        if steps:
            rec.log(
                "world/yaw/polytope/dimensions",
                rr.Points3D(
                    [[s.distance_m, 0.0, s.top_z_m + 0.05] for s in steps],
                    labels=[step_label(i, s) for i, s in enumerate(steps, 1)],
                    radii=0.01,
                ),
            )

    def close(self) -> None:
        """Flush; a saved recording is renamed onto its target."""
        try:
            self.rec.flush()
            self.rec.disconnect()
        except Exception as exc:  # the viewer went away (closed, or could not open a window)
            from ..errors import InputError

            self.abort()
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InputError(f"the Rerun viewer could not be reached: {first[:200]}") from None
        if self._tmp is not None and self.target is not None:
            try:
                mask = os.umask(0)
                os.umask(mask)
                os.chmod(self._tmp, 0o666 & ~mask)
                os.replace(self._tmp, self.target)
            except OSError as exc:
                from ..errors import InputError

                self.abort()
                raise InputError(f"cannot write {self.target}: {exc.strerror}") from None
            self._tmp = None

    def abort(self) -> None:
        with contextlib.suppress(Exception):
            self.rec.disconnect()
        if self._tmp is not None:
            with contextlib.suppress(OSError):
                self._tmp.unlink()
            self._tmp = None
