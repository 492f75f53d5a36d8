"""A figure of what an MCAP file written by ``--mcap`` holds, drawn from the file alone.

Every message is decoded with the ``mcap`` reader and ``mcap-ros2-support``'s decoder (as
any ROS 2 tool would read it, not with this package's writer), and one pair is drawn:

1. ``/stereo_terrain/left/image_rect`` with the ``/stereo_terrain/cloud`` points projected
   back into it through ``/tf`` (``yaw -> ... -> camera_rect``) and
   ``/stereo_terrain/left/camera_info``, coloured by their ``plane`` field: where the
   colours sit on the faces they came from, the tf chain and the camera model agree;
2. ``/stereo_terrain/disparity`` (32FC1);
3. the cloud and the ``/stereo_terrain/stairs`` markers (faces, edges, dimension texts)
   seen from the side, in the ``yaw`` frame.

Needs the ``ros`` and ``viz`` extras. ``python -m stereo_terrain.viz.mcap_figure IN.mcap
OUT.png [PAIR]``, with the exit codes of every command: 0 drawn, 2 a missing, empty or
damaged file, a file without these topics, a PAIR past its last pair, bad arguments or a
missing extra (one line on stderr), 1 an internal error.
"""

from __future__ import annotations

import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import EXIT_OK, EXIT_USAGE, InputError, exit_code
from ..ros import (
    TOPIC_CAMERA_INFO,
    TOPIC_CLOUD,
    TOPIC_DISPARITY,
    TOPIC_IMAGE,
    TOPIC_STAIRS,
    TOPIC_TERRAIN,
    TOPIC_TF,
)
from ..ros.messages import PALETTE

PROG = "python -m stereo_terrain.viz.mcap_figure"
#: What the figure draws: the topics every pair of ``--mcap`` has.
TOPICS = (TOPIC_IMAGE, TOPIC_DISPARITY, TOPIC_CLOUD, TOPIC_TF, TOPIC_CAMERA_INFO, TOPIC_TERRAIN, TOPIC_STAIRS)


#: Topics whose messages carry the pair's stamp in their header (one message per pair).
PAIR_STAMPED = (TOPIC_IMAGE, TOPIC_DISPARITY, TOPIC_CLOUD, TOPIC_CAMERA_INFO)


def read_pair(path: str | Path, pair: int = 0) -> dict[str, Any]:
    """The decoded messages of the ``pair``-th processed pair: topic -> message (the
    terrain message the one stamped like the pair, see :func:`pair_terrain`).

    :class:`InputError` when ``path`` is missing, not a file, or not a whole MCAP file
    (empty, truncated, damaged), holds no pair ``pair`` (it holds fewer), or has terrain
    messages but none of that pair."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path = Path(path)
    if not path.exists():
        raise InputError(f"MCAP file not found: {path}")
    if not path.is_file():
        raise InputError(f"{path} is not a file; give an MCAP file written by --mcap")
    seen: dict[str, list[Any]] = defaultdict(list)
    terrain_log_ns: list[int] = []  # the log time of each message in seen[TOPIC_TERRAIN]
    try:
        with path.open("rb") as fh:
            for _, channel, message, decoded in make_reader(
                fh, decoder_factories=[DecoderFactory()]
            ).iter_decoded_messages():
                seen[channel.topic].append(decoded)
                if channel.topic == TOPIC_TERRAIN:
                    terrain_log_ns.append(message.log_time)
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    except Exception as exc:  # mcap and its decoders raise many kinds for a damaged file
        text = " ".join(str(exc).split())
        why = f"{type(exc).__name__}: {text[:200]}" if text else type(exc).__name__
        raise InputError(
            f"cannot read {path} as an MCAP file ({why}); give a whole file written by --mcap, "
            "not an empty or cut-off one"
        ) from None
    # Every processed pair writes one message on each of these; heartbeats add terrain
    # messages only, so the terrain topic does not count the pairs (its message of the pair
    # is found by the pair's stamp, below).
    counts = [len(seen[t]) for t in TOPICS if t != TOPIC_TERRAIN and seen.get(t)]
    if counts and pair >= min(counts):
        n = min(counts)
        valid = "PAIR 0" if n == 1 else f"PAIR 0 to {n - 1}"
        pairs = "1 pair" if n == 1 else f"{n} pairs"
        raise InputError(f"{path} holds {pairs}, so there is no pair {pair}; give {valid}")
    chosen = {topic: msgs[min(pair, len(msgs) - 1)] for topic, msgs in seen.items()}
    stamp_ns = next(
        (_stamp_ns(getattr(chosen[t], "header", None)) for t in PAIR_STAMPED if len(seen.get(t, ())) > pair),
        None,
    )
    if stamp_ns is not None and seen.get(TOPIC_TERRAIN):
        terrain = pair_terrain(seen[TOPIC_TERRAIN], terrain_log_ns, stamp_ns)
        if terrain is None:
            sec, nsec = divmod(stamp_ns, 1_000_000_000)
            raise InputError(
                f"{path} has no {TOPIC_TERRAIN} message for pair {pair} (stamped {sec}.{nsec:09d} s); "
                "give an MCAP file written by reconstruct or replay --mcap"
            )
        chosen[TOPIC_TERRAIN] = terrain
    return chosen


def _stamp_ns(header: Any) -> int | None:
    """A header's stamp in epoch ns (None for a message without one: not written by us)."""
    stamp = getattr(header, "stamp", None)
    if stamp is None:
        return None
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def pair_terrain(terrains: list[Any], log_ns: list[int], stamp_ns: int) -> Any:
    """The terrain message of the pair stamped ``stamp_ns`` (epoch ns), or None.

    The terrain topic does not count the pairs: the live loop's stale heartbeats re-send the
    last terrain between pairs, stamped (header) like the pair they re-send, logged later by
    their age (:class:`~stereo_terrain.ros.mcap_out.McapSink`). So the pair's own message
    is one stamped like the pair's images, preferring the one logged at that stamp (written
    with the pair; a heartbeat is logged ``age_s`` later), then one not marked stale (a slow
    pair's own message is stale too), then the first in the file."""
    own = [
        (log != stamp_ns, bool(getattr(msg, "stale", False)), k)
        for k, (msg, log) in enumerate(zip(terrains, log_ns, strict=True))
        if _stamp_ns(getattr(msg, "header", None)) == stamp_ns
    ]
    return terrains[min(own)[2]] if own else None


def _quat_matrix(q: Any) -> np.ndarray:
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def transform_between(tf: Any, target: str, source: str) -> np.ndarray:
    """4x4 ``T_target_source`` from a ``TFMessage``: both frames' chains of parents up to
    their common root, composed (ValueError when they do not meet)."""
    parent = {}
    for t in tf.transforms:
        T = np.eye(4)
        T[:3, :3] = _quat_matrix(t.transform.rotation)
        p = t.transform.translation
        T[:3, 3] = [p.x, p.y, p.z]
        parent[t.child_frame_id] = (t.header.frame_id, T)

    def to_root(frame: str) -> tuple[str, np.ndarray]:
        T = np.eye(4)
        for _ in range(len(parent) + 1):
            if frame not in parent:
                return frame, T
            frame, step = parent[frame]
            T = step @ T
        raise ValueError("tf has a cycle")

    (root_t, T_rt), (root_s, T_rs) = to_root(target), to_root(source)
    if root_t != root_s:
        raise ValueError(f"tf does not connect {source} and {target}")
    return np.linalg.inv(T_rt) @ T_rs


def cloud_arrays(msg: Any) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) float32 points and (N,) int32 plane labels of our ``PointCloud2``."""
    offsets = {f.name: f.offset for f in msg.fields}
    n = msg.width * msg.height
    raw = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(n, msg.point_step)

    def col(name: str, dtype: str) -> np.ndarray:
        return raw[:, offsets[name] : offsets[name] + 4].copy().view(dtype)[:, 0]

    return np.stack([col(c, "<f4") for c in "xyz"], axis=1), col("plane", "<i4")


def save_mcap_figure(path: str | Path, out: str | Path, pair: int = 0) -> None:
    """Draw pair ``pair`` of the MCAP file ``path`` into the PNG ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    msgs = read_pair(path, pair)
    missing = [t for t in TOPICS if t not in msgs]
    if missing:
        raise InputError(
            f"{path} has no {missing[0]} messages ({len(missing)} of the {len(TOPICS)} topics missing); "
            "give an MCAP file written by reconstruct or replay --mcap"
        )
    img_msg, disp_msg = msgs["/stereo_terrain/left/image_rect"], msgs["/stereo_terrain/disparity"]
    image = np.frombuffer(bytes(img_msg.data), dtype=np.uint8).reshape(img_msg.height, img_msg.step)
    disp = np.frombuffer(bytes(disp_msg.data), dtype="<f4").reshape(disp_msg.height, disp_msg.width)
    cloud = msgs["/stereo_terrain/cloud"]
    xyz, labels = cloud_arrays(cloud)
    colours = np.where(labels[:, None] >= 0, PALETTE[np.maximum(labels, 0) % len(PALETTE)], 128) / 255.0
    T = transform_between(msgs["/tf"], "camera_rect", cloud.header.frame_id)
    cam = xyz @ T[:3, :3].T + T[:3, 3]
    P = np.asarray(msgs["/stereo_terrain/left/camera_info"].p, dtype=np.float64).reshape(3, 4)
    uvw = cam @ P[:, :3].T + P[:, 3]
    front = uvw[:, 2] > 0
    uv = uvw[front, :2] / uvw[front, 2:3]

    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    ax = axes[0]
    ax.imshow(image[:, : img_msg.width], cmap="gray")
    ax.scatter(uv[:, 0], uv[:, 1], s=2, c=colours[front])
    ax.set_title("image_rect + cloud through /tf and camera_info", fontsize=10)
    ax.axis("off")
    ax = axes[1]
    im = ax.imshow(disp, cmap="turbo")
    fig.colorbar(im, ax=ax, fraction=0.035, label="disparity (px)")
    ax.set_title("/stereo_terrain/disparity (32FC1, NaN = none)", fontsize=10)
    ax.axis("off")
    ax = axes[2]
    terrain = msgs["/stereo_terrain/terrain"]
    yaw = float(terrain.yaw_rad) if np.isfinite(terrain.yaw_rad) else 0.0
    c, sn = np.cos(yaw), np.sin(yaw)

    def along(p: np.ndarray) -> np.ndarray:  # position along the stair axis
        return p[..., 0] * c + p[..., 1] * sn

    ax.scatter(along(xyz), xyz[:, 2], s=1, c=colours)
    for marker in msgs["/stereo_terrain/stairs"].markers:
        pts = np.array([[p.x, p.y, p.z] for p in marker.points]).reshape(-1, 3)
        if marker.type == 5 and len(pts):  # LINE_LIST: the polytope's edges
            for a, b in pts.reshape(-1, 2, 3):
                ax.plot([along(a), along(b)], [a[2], b[2]], color="k", lw=0.8)
        elif marker.type == 9 and marker.ns == "dimensions":
            p = marker.pose.position
            ax.annotate(marker.text, (along(np.array([p.x, p.y])), p.z), fontsize=7, xytext=(-60, 14),
                        textcoords="offset points", arrowprops={"arrowstyle": "-", "lw": 0.5})  # fmt: skip
    ax.set_title(
        f"cloud (by plane) + /stereo_terrain/stairs along the stair axis; {terrain.num_steps} steps",
        fontsize=10,
    )
    ax.set_xlabel("along the stair axis (m)")
    ax.set_ylabel("z up (m)")
    ax.set_aspect("equal")
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    """``python -m stereo_terrain.viz.mcap_figure IN.mcap OUT.png [PAIR]``; the exit code.

    The optional packages and the output are checked before the file is read; the figure is
    written to a temporary name and renamed, so a failure leaves no half-written figure.
    """
    from ..cli.options import Parser, figure_path
    from ..cli.outputs import check_output_file, replace_from_temp, require, require_viz

    parser = Parser(prog=PROG, description="A figure of what an MCAP file written by --mcap holds.")
    parser.add_argument("mcap", type=Path, help="IN.mcap, written by reconstruct or replay --mcap")
    parser.add_argument("out", type=figure_path, help="OUT.png (or .pdf, .svg, .jpg)")
    parser.add_argument("pair", type=int, nargs="?", default=0, help="which processed pair (default 0)")
    args = parser.parse_args(argv)
    if args.pair < 0:
        parser.error(f"argument pair: expected an integer >= 0, got {args.pair}")
    try:
        for module in ("mcap", "mcap_ros2"):
            require(module, "ros", "reading the MCAP file")
        require_viz("the figure")
        check_output_file(args.out, "OUT")
        replace_from_temp(args.out, lambda tmp: save_mcap_figure(args.mcap, tmp, args.pair))
    except (Exception, KeyboardInterrupt) as exc:
        code = exit_code(exc)
        if isinstance(exc, KeyboardInterrupt):
            line = "interrupted"
        elif code == EXIT_USAGE and isinstance(exc, OSError):
            line = f"error: cannot use {exc.filename}: {exc.strerror or exc}"
        elif code == EXIT_USAGE:
            line = "error: " + " ".join(str(exc).split())
        else:
            line = (
                f"internal error: {type(exc).__name__}: {' '.join(str(exc).split())[:500]} (please report it)"
            )
        sys.stderr.write(f"{PROG}: {line}\n")
        return code
    print(f"wrote {args.out}")
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())
