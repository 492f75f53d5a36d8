"""A corpus of user mistakes over every command and file format (issue 12).

Each bad case must give exit code 2, exactly one line on stderr naming the file or option,
no traceback, and leave the output location as it was (snapshot before and after). A few
legal-but-odd inputs must run with exit 0. Tiny images (64x48) and calibrations keep the
whole file fast; most cases run in-process, a handful as real subprocesses.
"""

# ruff: noqa: E501  (the corpus is a table, one case a line)
from __future__ import annotations

import hashlib
import json
import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from stereo_terrain.calibration import StereoCalibration, write_opencv_yaml
from stereo_terrain.cli import main
from stereo_terrain.stereo.io import write_pfm

W, H = 64, 48
SRC = Path(__file__).resolve().parents[1] / "src"


# ----------------------------------------------------------------- file makers


def _png(arr: np.ndarray, colour_type: int) -> bytes:
    """A PNG of ``arr`` ((H, W) or (H, W, C), uint8 or uint16) with the given colour type,
    written by hand so that grey+alpha (type 4), which OpenCV cannot write, is possible."""
    a = arr if arr.ndim == 3 else arr[:, :, None]
    depth = 16 if a.dtype == np.uint16 else 8
    raw = b"".join(b"\x00" + row.astype(">u2" if depth == 16 else "u1").tobytes() for row in a)
    return _png_chunks(a.shape[1], a.shape[0], depth, colour_type, zlib.compress(raw))


def _png_chunks(w: int, h: int, depth: int, colour_type: int, idat: bytes) -> bytes:
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", w, h, depth, colour_type, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def _calib(w: int = W, h: int = H, **kw) -> StereoCalibration:
    f = 0.85 * w
    K = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1.0]])
    args = dict(K1=K, D1=np.zeros(5), K2=K, D2=np.zeros(5), R=np.eye(3), T=np.array([-0.08, 0, 0]))
    args.update(kw)
    return StereoCalibration(image_size=(w, h), **args)


_OPENCV_YAML = """%YAML:1.0
---
image_width: {w}
image_height: {h}
K1: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ {f}, 0., 31.5, 0., {f}, 23.5, 0., 0., 1. ]
D1: [ 0., 0., 0., 0., 0. ]
K2: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ {f}, 0., 31.5, 0., {f}, 23.5, 0., 0., 1. ]
D2: [ 0., 0., 0., 0., 0. ]
R: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]
T: [ {t}, 0., 0. ]
"""


def _yaml(w="64", h="48", f="54.4", t="-0.08") -> str:
    return _OPENCV_YAML.format(w=w, h=h, f=f, t=t)


def _middlebury(**over) -> str:
    v = dict(
        cam0="[54.4 0 31.5; 0 54.4 23.5; 0 0 1]",
        cam1="[54.4 0 31.5; 0 54.4 23.5; 0 0 1]",
        doffs="0",
        baseline="80",
        width="64",
        height="48",
        ndisp="16",
    )
    v.update(over)
    return "".join(f"{k}={x}\n" for k, x in v.items() if x is not None)


def _stereodemo(**over) -> str:
    v: dict = dict(fx=54.4, fy=54.4, cx0=31.5, cx1=31.5, cy=23.5, baseline_meters=0.08, width=64, height=48)
    v.update(over)
    return json.dumps({k: x for k, x in v.items() if x is not None})


def _rig(t=(0.0, 0.0, 0.5), rpy="[0.0, 0.0, 0.0]") -> str:
    R = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
    rows = [R[i] + [t[i]] for i in range(3)] + [[0, 0, 0, 1]]
    return f"T_body_camera: {json.dumps(rows)}\nbody_rpy: {rpy}\n"


# ----------------------------------------------------------------- fixtures


class Files:
    """Good inputs shared by every case (never modified by a case)."""


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Files:
    d = tmp_path_factory.mktemp("good")
    g = Files()
    rng = np.random.default_rng(0)
    base = cv2.GaussianBlur((rng.random((H, W + 8)) * 255).astype(np.uint8), (3, 3), 0)
    left, right = base[:, 8:], base[:, :W]  # 8 px of disparity
    g.dir = d
    g.left, g.right = d / "left.png", d / "right.png"
    cv2.imwrite(str(g.left), left)
    cv2.imwrite(str(g.right), right)
    g.left_arr, g.right_arr = left, right
    g.calib = d / "calib.yaml"
    write_opencv_yaml(_calib(), g.calib)
    g.rig = d / "rig.yaml"
    g.rig.write_text(_rig())
    g.config = d / "config.yaml"
    g.config.write_text("min_depth_m: 0.7\n")
    # A Middlebury-layout scene.
    g.mb = d / "mb" / "scene"
    g.mb.mkdir(parents=True)
    cv2.imwrite(str(g.mb / "im0.png"), left)
    cv2.imwrite(str(g.mb / "im1.png"), right)
    (g.mb / "calib.txt").write_text(_middlebury())
    write_pfm(g.mb / "disp0GT.pfm", np.full((H, W), 8.0, np.float32))
    cv2.imwrite(str(g.mb / "mask0nocc.png"), np.full((H, W), 255, np.uint8))
    # A recording.
    g.rec = d / "rec"
    g.rec.mkdir()
    lines = ["index,t_left,t_right,left,right"]
    for i in range(3):
        cv2.imwrite(str(g.rec / f"l{i}.png"), left)
        cv2.imwrite(str(g.rec / f"r{i}.png"), right)
        lines.append(f"{i},{i / 10},{i / 10},l{i}.png,r{i}.png")
    (g.rec / "pairs.csv").write_text("\n".join(lines) + "\n")
    write_opencv_yaml(_calib(), g.rec / "calib.yaml")
    return g


class Case:
    def __init__(self, name: str, build, words: tuple[str, ...] = (), *, subprocess: bool = False):
        self.name, self.build, self.words, self.subprocess = name, build, words, subprocess

    def __repr__(self) -> str:
        return self.name


def _snapshot(folder: Path) -> dict[str, str]:
    out = {}
    for p in sorted(folder.rglob("*")):
        rel = str(p.relative_to(folder))
        out[rel] = "dir" if p.is_dir() else hashlib.sha1(p.read_bytes()).hexdigest()
    return out


def _write(path: Path, data: str | bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(data, bytes):
        path.write_bytes(data)
    else:
        path.write_text(data)
    return path


def _run_cli(argv: list[str], cwd: Path, capfd, use_subprocess: bool) -> tuple[int, str]:
    argv = [str(a) for a in argv]
    if use_subprocess:
        env = dict(os.environ, PYTHONPATH=str(SRC))
        p = subprocess.run(
            [sys.executable, "-m", "stereo_terrain.cli", *argv],
            cwd=cwd, env=env, capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        return p.returncode, p.stderr
    old = os.getcwd()
    os.chdir(cwd)
    try:
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse
            code = exc.code
    finally:
        os.chdir(old)
    return code, capfd.readouterr().err


# ----------------------------------------------------------------- the corpus
# build(g, w) -> argv, where g holds the good files and w is the case's own folder; the
# output location is w / "out" (it holds keep.json), which is also the working directory.


def _recon(left, right, calib, *extra):
    return ["reconstruct", left, right, "--calib", calib, *extra]


def _bad_calib(name, text, *words, sub=False):
    def build(g, w):
        return _recon(g.left, g.right, _write(w / name, text), "--json", w / "out" / "r.json")

    return Case(f"calib-{name}", build, (name, *words), subprocess=sub)


def _bad_rig(label, text):
    def build(g, w):
        return _recon(g.left, g.right, g.calib, "--rig", _write(w / f"{label}.yaml", text))

    return Case(f"rig-{label}", build, (f"{label}.yaml",))


def _bad_config(label, text):
    def build(g, w):
        return _recon(g.left, g.right, g.calib, "--config", _write(w / f"{label}.yaml", text))

    return Case(f"config-{label}", build, (f"{label}.yaml",))


def _bad_image(label, data, ext="png", cmd="reconstruct"):
    def build(g, w):
        bad = _write(w / f"{label}.{ext}", data() if callable(data) else data)
        if cmd == "disparity":
            return ["disparity", bad, g.right, "--calib", g.calib, "--out", w / "out" / "d.pfm"]
        if cmd == "check-calib":
            return ["check-calib", g.left, bad, "--calib", g.calib]
        return _recon(bad, g.right, g.calib, "--json", w / "out" / "r.json")

    return Case(f"image-{cmd}-{label}", build, (f"{label}.{ext}",))


def _jpeg(cut: bool):
    def make():
        img = (np.random.default_rng(1).random((H, W)) * 255).astype(np.uint8)
        b = cv2.imencode(".jpg", img)[1].tobytes()
        if cut:
            return b[: len(b) // 2]
        g = bytearray(b)
        g[len(g) // 2 : len(g) // 2 + 8] = b"\xff\xd5\xff\xd3\x00\x12\x34\x56"
        return bytes(g)

    return make


def _tiff(dtype):
    def make():
        a = (np.random.default_rng(2).random((H, W, 3)) * 100).astype(dtype)
        return cv2.imencode(".tiff", a)[1].tobytes()

    return make


def _mb_case(label, mutate, *words):
    """eval-disparity on a copy of the good Middlebury scene changed by ``mutate(scene_dir)``."""

    def build(g, w):
        import shutil

        scene = w / "mb" / "scene"
        shutil.copytree(g.mb, scene)
        mutate(scene)
        return ["eval-disparity", w / "mb", "--method", "opencv"]

    return Case(f"eval-{label}", build, words)


def _pfm_case(label, header: bytes, body: bytes = b""):
    return _mb_case(f"pfm-{label}", lambda s: (s / "disp0GT.pfm").write_bytes(header + body), "disp0GT.pfm")


def _rec_case(label, csv_text: str | bytes, *words, images=True):
    def build(g, w):
        rec = w / "rec"
        rec.mkdir()
        if images:
            for i in range(3):
                cv2.imwrite(str(rec / f"l{i}.png"), g.left_arr)
                cv2.imwrite(str(rec / f"r{i}.png"), g.right_arr)
        _write(rec / "pairs.csv", csv_text)
        return ["replay", rec, "--calib", g.calib, "--no-lcm", "--as-fast"]

    return Case(f"replay-{label}", build, words or ("pairs.csv",))


def _replay_without_calib(g, w):
    """replay of a recording as record writes it: pairs.csv and the images, no calib.yaml."""
    import shutil

    rec = shutil.copytree(g.rec, w / "rec", ignore=shutil.ignore_patterns("calib.yaml"))
    return ["replay", rec, "--no-lcm"]


def _sim(label, *opts):
    return Case(
        f"simulate-{label}",
        lambda g, w: ["simulate", "--out", w / "out" / "sim", "--no-plot", *opts],
        (opts[0],),
    )


def _out(w: Path, *parts: str) -> Path:
    return w.joinpath("out", *parts)


DEEP = "[" * 20000
CSV_HEAD = "index,t_left,t_right,left,right\n"

CASES = [
    # --- usage (argparse) ---
    Case("no-command", lambda g, w: [], ("stereo-terrain",)),
    Case("unknown-command", lambda g, w: ["frobnicate"], ("frobnicate",)),
    Case("reconstruct-no-calib", lambda g, w: ["reconstruct", g.left, g.right], ("--calib",)),
    Case("reconstruct-maxdisp-0", lambda g, w: _recon(g.left, g.right, g.calib, "--max-disparity", "0"),
         ("--max-disparity",)),
    Case("reconstruct-maxdisp-text", lambda g, w: _recon(g.left, g.right, g.calib, "--max-disparity", "x"),
         ("--max-disparity",)),
    Case("reconstruct-maxdisp-huge", lambda g, w: _recon(g.left, g.right, g.calib, "--max-disparity",
                                                          "99999999999"), ("--max-disparity",)),
    Case("reconstruct-method", lambda g, w: _recon(g.left, g.right, g.calib, "--method", "hough"),
         ("--method",)),
    Case("reconstruct-plot-suffix", lambda g, w: _recon(g.left, g.right, g.calib, "--plot", _out(w, "p.txt")),
         ("--plot",)),
    Case("render-size-small", lambda g, w: ["render", "--out", _out(w, "r"), "--size", "10x10"], ("--size",)),
    Case("render-size-text", lambda g, w: ["render", "--out", _out(w, "r"), "--size", "axb"], ("--size",)),
    Case("render-size-huge", lambda g, w: ["render", "--out", _out(w, "r"), "--size", "99999x99999"],
         ("--size",)),
    Case("render-count-0", lambda g, w: ["render", "--out", _out(w, "r"), "--count", "0"], ("--count",)),
    Case("render-count-neg", lambda g, w: ["render", "--out", _out(w, "r"), "--count", "-3"], ("--count",)),
    Case("render-seed-neg", lambda g, w: ["render", "--out", _out(w, "r"), "--seed", "-1"], ("--seed",)),
    Case("render-kind", lambda g, w: ["render", "--out", _out(w, "r"), "--kind", "ramp"], ("--kind",)),
    Case("render-out-is-file", lambda g, w: ["render", "--out", _out(w, "keep.json")], ("--out",)),
    Case("disparity-out-suffix", lambda g, w: ["disparity", g.left, g.right, "--calib", g.calib, "--out",
                                              _out(w, "d.bmp")], ("--out",)),
    Case("disparity-method", lambda g, w: ["disparity", g.left, g.right, "--calib", g.calib, "--method", "x",
                                          "--out", _out(w, "d.pfm")], ("--method",)),
    Case("disparity-out-missing-dir", lambda g, w: ["disparity", g.left, g.right, "--calib", g.calib, "--out",
                                                   _out(w, "no", "d.pfm")], ("--out",)),
    Case("disparity-out-is-dir", lambda g, w: ["disparity", g.left, g.right, "--calib", g.calib, "--out",
                                              _out(w, "sub.pfm")], ("--out",)),
    Case("calibrate-square-text", lambda g, w: ["calibrate", "--left", "l*", "--right", "r*", "--pattern",
                                               "9x6", "--square", "abc", "--out", _out(w, "c.yaml")],
         ("--square",)),
    Case("calibrate-square-nan", lambda g, w: ["calibrate", "--left", "l*", "--right", "r*", "--pattern",
                                              "9x6", "--square", "nan", "--out", _out(w, "c.yaml")],
         ("square",)),
    Case("calibrate-square-neg", lambda g, w: ["calibrate", "--left", str(g.dir / "l*.png"), "--right",
                                              str(g.dir / "r*.png"), "--pattern", "9x6", "--square", "-0.02",
                                              "--out", _out(w, "c.yaml")], ("square",)),
    Case("calibrate-pattern", lambda g, w: ["calibrate", "--left", "l*", "--right", "r*", "--pattern",
                                           "9by6", "--square", "0.025", "--out", _out(w, "c.yaml")],
         ("9by6",)),
    Case("calibrate-out-suffix", lambda g, w: ["calibrate", "--left", "l*", "--right", "r*", "--pattern",
                                              "9x6", "--square", "0.025", "--out", _out(w, "c.txt")],
         ("--out",)),
    Case("calibrate-out-missing-dir", lambda g, w: ["calibrate", "--left", str(g.dir / "l*.png"), "--right",
                                                   str(g.dir / "r*.png"), "--pattern", "9x6", "--square",
                                                   "0.025", "--out", _out(w, "no", "c.yaml")], ("--out",)),
    Case("calibrate-figure-missing-dir", lambda g, w: ["calibrate", "--left", str(g.dir / "l*.png"),
                                                      "--right", str(g.dir / "r*.png"), "--pattern", "9x6",
                                                      "--square", "0.025", "--out", _out(w, "c.yaml"),
                                                      "--figure", _out(w, "no", "f.png")], ("--figure",)),
    Case("calibrate-no-match", lambda g, w: ["calibrate", "--left", str(w / "none*.png"), "--right",
                                            str(w / "none*.png"), "--pattern", "9x6", "--square", "0.025",
                                            "--out", _out(w, "c.yaml")], ("none*.png",)),
    Case("calibrate-no-board", lambda g, w: ["calibrate", "--left", str(g.dir / "left.png"), "--right",
                                            str(g.dir / "right.png"), "--pattern", "9x6", "--square", "0.025",
                                            "--out", _out(w, "c.yaml")], ("9x6",)),
    Case("check-calib-odd", lambda g, w: ["check-calib", g.left, "--calib", g.calib], ("pairs",)),
    Case("check-calib-missing-calib", lambda g, w: ["check-calib", g.left, g.right, "--calib",
                                                   w / "nope.yaml"], ("nope.yaml",)),
    # --- simulate options ---
    _sim("rise-neg", "--rise", "-1"),
    _sim("rise-huge", "--rise", "5"),
    _sim("start-1e308", "--start", "1e308"),
    _sim("start-short", "--start", "0.3"),
    _sim("fps-1e308", "--fps", "1e308"),
    _sim("fps-0", "--fps", "0"),
    _sim("fps-nan", "--fps", "nan"),
    _sim("speed-tiny", "--speed", "1e-300", "--fps", "1e9"),
    _sim("speed-0", "--speed", "0"),
    _sim("run-0", "--run", "0"),
    _sim("size", "--size", "8x8"),
    Case("simulate-out-is-file", lambda g, w: ["simulate", "--out", _out(w, "keep.json"), "--no-plot"],
         ("--out",)),
    Case("simulate-record-existing", lambda g, w: ["simulate", "--out", _out(w, "sim"), "--no-plot",
                                                  "--record", g.rec], ("--record",)),
    # --- record / run ---
    Case("record-frames-0", lambda g, w: ["record", "--left", "0", "--right", "1", "--out", _out(w, "r"),
                                         "--frames", "0"], ("--frames",)),
    Case("record-skew-neg", lambda g, w: ["record", "--left", "0", "--right", "1", "--out", _out(w, "r"),
                                         "--max-skew-ms", "-1"], ("--max-skew-ms",)),
    Case("record-missing-video", lambda g, w: ["record", "--left", w / "l.avi", "--right", w / "r.avi",
                                              "--out", _out(w, "r")], ("l.avi",)),
    Case("record-mixed", lambda g, w: ["record", "--left", "0", "--right", g.left, "--out", _out(w, "r")],
         ("video",)),
    Case("record-out-existing", lambda g, w: ["record", "--left", g.left, "--right", g.right, "--out", g.rec],
         ("rec",)),
    Case("run-missing-video", lambda g, w: ["run", "--left", w / "l.avi", "--right", w / "r.avi", "--calib",
                                           g.calib, "--no-lcm"], ("l.avi",)),
    Case("run-missing-calib", lambda g, w: ["run", "--left", w / "l.avi", "--right", w / "r.avi", "--calib",
                                           w / "nope.yaml", "--no-lcm"], ("nope.yaml",)),
    Case("run-stall-nan", lambda g, w: ["run", "--left", "0", "--right", "1", "--calib", g.calib,
                                       "--stall-timeout", "nan"], ("--stall-timeout",)),
    # --- replay ---
    Case("replay-missing-folder", lambda g, w: ["replay", w / "MISSING", "--no-lcm"], ("MISSING",)),
    Case("replay-folder-is-file", lambda g, w: ["replay", g.calib, "--no-lcm"], ("calib.yaml",)),
    Case("replay-no-pairs", lambda g, w: ["replay", g.dir, "--no-lcm", "--calib", g.calib], ("pairs.csv",)),
    Case("replay-no-calib", _replay_without_calib, ("--calib",)),
    Case("replay-not-a-recording", lambda g, w: ["replay", g.mb, "--no-lcm"], ("not a recording", "pairs.csv")),
    Case("replay-speed-0", lambda g, w: ["replay", g.rec, "--no-lcm", "--speed", "0"], ("--speed",)),
    Case("replay-summary-missing-dir", lambda g, w: ["replay", g.rec, "--no-lcm", "--summary-json",
                                                    _out(w, "no", "s.json")], ("--summary-json",)),
    _rec_case("columns", "a,b,c\n1,2,3\n"),
    _rec_case("not-numbers", CSV_HEAD + "0,x,0,l0.png,r0.png\n"),
    _rec_case("nan-time", CSV_HEAD + "0,nan,0,l0.png,r0.png\n"),
    _rec_case("inf-time", CSV_HEAD + "0,inf,inf,l0.png,r0.png\n"),
    _rec_case("huge-time", CSV_HEAD + "0,1e300,1e300,l0.png,r0.png\n"),
    _rec_case("not-utf8", CSV_HEAD.encode() + b"0,0,0,l\xff\xfe.png,r0.png\n"),
    _rec_case("empty", ""),
    _rec_case("header-only", CSV_HEAD),
    _rec_case("short-row", CSV_HEAD + "0,0\n"),
    _rec_case("nul-byte", CSV_HEAD + "0,0,0,l\x000.png,r0.png\n"),
    _rec_case("images-missing", CSV_HEAD + "0,0,0,l0.png,r0.png\n1,0.1,0.1,l1.png,r1.png\n",
              "l0.png", images=False),
    Case("replay-wrong-size", lambda g, w: ["replay", g.rec, "--calib", _write(w / "big.yaml", _yaml("128", "96")),
                                           "--no-lcm", "--as-fast"], ("64x48",)),
    # --- calibrations: OpenCV YAML / XML ---
    Case("calib-missing", lambda g, w: _recon(g.left, g.right, w / "nope.yaml"), ("nope.yaml",)),
    Case("calib-folder", lambda g, w: _recon(g.left, g.right, g.dir), ("folder",)),
    _bad_calib("empty.yaml", ""),
    _bad_calib("garbage.yaml", b"\x00\x01\x02\xff" * 100),
    _bad_calib("latin1.yaml", _yaml().replace("K1", "K1").encode() + "# caf\xe9\n".encode("latin-1"),
               sub=True),
    _bad_calib("list-root.yaml", "%YAML:1.0\n---\n- 1\n- 2\n"),
    _bad_calib("deep.yaml", "%YAML:1.0\n---\nK1: " + DEEP + "\n", sub=True),
    _bad_calib("no-k1.yaml", _yaml().replace("K1:", "K9:")),
    _bad_calib("k1-text.yaml", _yaml().replace("data: [ 54.4, 0., 31.5", "data: [ abc, 0., 31.5", 1)),
    _bad_calib("width-inf.yaml", _yaml(w=".inf")),
    _bad_calib("width-nan.yaml", _yaml(w=".nan")),
    _bad_calib("width-neg.yaml", _yaml(w="-64")),
    _bad_calib("width-frac.yaml", _yaml(w="64.5")),
    _bad_calib("width-huge.yaml", _yaml(w="1e12")),
    _bad_calib("width-text.yaml", _yaml(w="wide")),
    _bad_calib("focal-tiny.yaml", _yaml(f="1e-300")),
    _bad_calib("focal-huge.yaml", _yaml(f="1e300")),
    _bad_calib("focal-nan.yaml", _yaml(f=".nan")),
    _bad_calib("t-mm.yaml", _yaml(t="-80.0")),
    _bad_calib("t-zero.yaml", _yaml(t="0.0")),
    _bad_calib("r-not-rotation.yaml", _yaml().replace("data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]",
                                                      "data: [ 2., 0., 0., 0., 1., 0., 0., 0., 1. ]")),
    _bad_calib("d-count.yaml", _yaml().replace("D1: [ 0., 0., 0., 0., 0. ]", "D1: [ 0., 0., 0. ]")),
    _bad_calib("size-mismatch.yaml", _yaml(w="128", h="96")),
    _bad_calib("bad.xml", "<?xml version='1.0'?>\n<opencv_storage><K1>1 2"),
    _bad_calib("no-k1.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>64</image_width>\n"
                            "</opencv_storage>\n"),
    # --- calibrations: Middlebury calib.txt ---
    _bad_calib("mb-no-baseline.txt", _middlebury(baseline=None) + "baseline_is=80\n"),
    _bad_calib("mb-ndisp-nan.txt", _middlebury(ndisp="nan")),
    _bad_calib("mb-ndisp-zero.txt", _middlebury(ndisp="0")),
    _bad_calib("mb-width-inf.txt", _middlebury(width="inf")),
    _bad_calib("mb-width-nan.txt", _middlebury(width="nan")),
    _bad_calib("mb-baseline-zero.txt", _middlebury(baseline="0")),
    _bad_calib("mb-baseline-nan.txt", _middlebury(baseline="nan")),
    _bad_calib("mb-cam0-short.txt", _middlebury(cam0="[54.4 0 31.5; 0 54.4 23.5]")),
    _bad_calib("mb-cam0-text.txt", _middlebury(cam0="[a b c; d e f; g h i]")),
    _bad_calib("mb-cam0-huge.txt", _middlebury(cam0="[1e300 0 31.5; 0 1e300 23.5; 0 0 1]")),
    _bad_calib("mb-doffs.txt", _middlebury(doffs="12")),
    _bad_calib("mb-latin1.txt", _middlebury().encode() + "vmin=caf\xe9\n".encode("latin-1")),
    # --- calibrations: stereodemo JSON ---
    _bad_calib("sd-invalid.json", "{not json"),
    _bad_calib("sd-list.json", "[1, 2, 3]"),
    _bad_calib("sd-missing.json", _stereodemo(fx=None)),
    _bad_calib("sd-text.json", _stereodemo(fx="wide")),
    _bad_calib("sd-nan.json", _stereodemo(fx=float("nan"))),
    _bad_calib("sd-width-inf.json", _stereodemo(width=float("inf"))),
    _bad_calib("sd-width-bool.json", _stereodemo(width=True)),
    _bad_calib("sd-baseline-neg.json", _stereodemo(baseline_meters=-0.08)),
    _bad_calib("sd-baseline-mm.json", _stereodemo(baseline_meters=80)),
    _bad_calib("sd-deep.json", DEEP),
    _bad_calib("sd-latin1.json", _stereodemo().encode()[:-1] + ', "n": "caf\xe9"}'.encode("latin-1")),
    # --- rig ---
    Case("rig-missing", lambda g, w: _recon(g.left, g.right, g.calib, "--rig", w / "nope.yaml"), ("nope.yaml",)),
    _bad_rig("empty", ""),
    _bad_rig("list", "- 1\n- 2\n"),
    _bad_rig("no-key", "T: 1\n"),
    _bad_rig("not-4x4", "T_body_camera: [[1, 0], [0, 1]]\n"),
    _bad_rig("text", "T_body_camera: [[a, b, c, d]]\n"),
    _bad_rig("not-rigid", "T_body_camera: [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"),
    _bad_rig("nan", "T_body_camera: [[1,0,0,.nan],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n"),
    _bad_rig("mm", _rig(t=(0.0, 0.0, 547.0))),
    _bad_rig("rpy-short", _rig(rpy="[0.1]")),
    _bad_rig("rpy-nan", _rig(rpy="[.nan, 0, 0]")),
    _bad_rig("rpy-degrees", _rig(rpy="[0, 90, 0]")),
    _bad_rig("deep", "T_body_camera: " + DEEP + "\n"),
    _bad_rig("invalid", "T_body_camera: [1, 2\n  - x: : :\n"),
    Case("rig-latin1", lambda g, w: _recon(g.left, g.right, g.calib, "--rig", _write(
        w / "latin1.yaml", _rig().encode() + "# caf\xe9\n".encode("latin-1"))), ("latin1.yaml",), subprocess=True),
    # --- pipeline config ---
    Case("config-missing", lambda g, w: _recon(g.left, g.right, g.calib, "--config", w / "nope.yaml"),
         ("nope.yaml",)),
    _bad_config("unknown-key", "frobnicate: 1\n"),
    _bad_config("list", "- 1\n"),
    _bad_config("wrong-type", "min_depth_m: deep\n"),
    _bad_config("nan", "min_depth_m: .nan\n"),
    _bad_config("inf", "min_depth_m: .inf\n"),
    _bad_config("p2-overflow", "sgbm: {p1_per_px: 8, p2_per_px: 100000000000}\n"),
    _bad_config("p2-float", "sgbm: {p2_per_px: 1.0e11}\n"),
    _bad_config("section-scalar", "sgbm: 3\n"),
    _bad_config("section-unknown", "sgbm: {bogus: 1}\n"),
    _bad_config("method", "method: hough\n"),
    _bad_config("backend", "backend: cuda9\n"),
    _bad_config("maxdisp-text", "max_disparity_px: many\n"),
    _bad_config("deep", "a: " + DEEP + "\n"),
    _bad_config("invalid", "a: [1, 2\n"),
    _bad_config("latin1", "# caf\xe9\n".encode("latin-1")),
    # --- images ---
    Case("image-missing", lambda g, w: _recon(w / "nope.png", g.right, g.calib), ("nope.png",), subprocess=True),
    Case("image-folder", lambda g, w: _recon(g.dir, g.right, g.calib), ("folder",)),
    _bad_image("empty", b""),
    _bad_image("text", b"hello, not an image\n"),
    _bad_image("truncated", lambda: cv2.imencode(".png", np.zeros((H, W), np.uint8) + 7)[1].tobytes()[:60]),
    _bad_image("bomb", _png_chunks(50000, 50000, 8, 0, zlib.compress(b"\x00" * 1000))),
    _bad_image("bomb20k", _png_chunks(20000, 20000, 8, 0, zlib.compress(b"\x00" * 1000))),
    _bad_image("zero-size", _png_chunks(0, 0, 8, 0, zlib.compress(b""))),
    _bad_image("float64", _tiff(np.float64), "tiff"),
    _bad_image("float32", _tiff(np.float32), "tiff"),
    _bad_image("int16", _tiff(np.int16), "tiff"),
    _bad_image("cut", _jpeg(cut=True), "jpg"),
    _bad_image("garbled", _jpeg(cut=False), "jpg"),
    _bad_image("cut", _jpeg(cut=True), "jpg", cmd="disparity"),
    _bad_image("bomb", _png_chunks(50000, 50000, 8, 0, zlib.compress(b"\x00" * 1000)), cmd="disparity"),
    _bad_image("float64", _tiff(np.float64), "tiff", cmd="check-calib"),
    _bad_image("cut", _jpeg(cut=True), "jpg", cmd="check-calib"),
    Case("image-size-pair", lambda g, w: _recon(g.left, _write(w / "small.png", cv2.imencode(
        ".png", np.zeros((40, 60), np.uint8))[1].tobytes()), g.calib), ("differ",)),
    # --- outputs ---
    Case("json-missing-dir", lambda g, w: _recon(g.left, g.right, g.calib, "--json", _out(w, "no", "r.json")),
         ("--json",)),
    Case("json-is-dir", lambda g, w: _recon(g.left, g.right, g.calib, "--json", _out(w, "sub.pfm")),
         ("--json",)),
    Case("json-then-bad-plot", lambda g, w: _recon(g.left, g.right, g.calib, "--json", _out(w, "keep.json"),
                                                   "--plot", _out(w, "no", "p.png")), ("--plot",), subprocess=True),
    Case("plot-is-dir", lambda g, w: _recon(g.left, g.right, g.calib, "--plot", _out(w, "fig.png")),
         ("--plot",)),
    Case("demo-out-is-file", lambda g, w: ["demo", "--out", _out(w, "keep.json")], ("--out",)),
    Case("demo-out-under-file", lambda g, w: ["demo", "--out", _out(w, "keep.json", "d")], ("--out",)),
    Case("render-out-under-file", lambda g, w: ["render", "--out", _out(w, "keep.json", "r")], ("--out",)),
    # --- eval-disparity (PFM, mask, sizes) ---
    Case("eval-missing", lambda g, w: ["eval-disparity", w / "nope"], ("nope",)),
    Case("eval-empty", lambda g, w: ["eval-disparity", _write(w / "e" / "x.txt", "").parent], ("e",)),
    _pfm_case("colour", b"PF\n64 48\n-1.0\n", b"\x00" * 64 * 48 * 12),
    _pfm_case("neg-dims", b"Pf\n-64 48\n-1.0\n"),
    _pfm_case("zero-dims", b"Pf\n0 0\n-1.0\n"),
    _pfm_case("huge-dims", b"Pf\n2000000000 2000000000\n-1.0\n", b"\x00" * 100),
    _pfm_case("truncated", b"Pf\n64 48\n-1.0\n", b"\x00" * 100),
    _pfm_case("text-dims", b"Pf\nsixty four\n-1.0\n"),
    _pfm_case("scale-nan", b"Pf\n64 48\nnan\n", b"\x00" * 64 * 48 * 4),
    _pfm_case("scale-zero", b"Pf\n64 48\n0\n", b"\x00" * 64 * 48 * 4),
    _pfm_case("empty", b""),
    _pfm_case("binary", bytes(range(256)) * 4),
    _pfm_case("other-size", b"Pf\n32 24\n-1.0\n", b"\x00" * 32 * 24 * 4),
    _mb_case("mask-corrupt", lambda s: (s / "mask0nocc.png").write_bytes(b"\x89PNG garbage"), "mask0nocc.png"),
    _mb_case("mask-size", lambda s: cv2.imwrite(str(s / "mask0nocc.png"), np.full((24, 32), 255, np.uint8)),
             "mask0nocc.png"),
    _mb_case("mask-empty", lambda s: cv2.imwrite(str(s / "mask0nocc.png"), np.zeros((H, W), np.uint8)),
             "mask0nocc.png"),
    _mb_case("im1-size", lambda s: cv2.imwrite(str(s / "im1.png"), np.zeros((24, 32), np.uint8)), "im1.png"),
    _mb_case("calib-nan", lambda s: (s / "calib.txt").write_text(_middlebury(ndisp="nan")), "calib.txt"),
    _mb_case("im0-text", lambda s: (s / "im0.png").write_text("not a png"), "im0.png"),
]  # fmt: skip


@pytest.fixture
def case_dir(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.json").write_text('{"previous": true}\n')
    (out / "sub.pfm").mkdir()
    (out / "fig.png").mkdir()
    return tmp_path


@pytest.mark.parametrize("case", CASES, ids=repr)
def test_bad_input_is_one_line_exit_2_and_nothing_written(case, good, case_dir, capfd):
    argv = case.build(good, case_dir)
    out = case_dir / "out"
    before = _snapshot(out)
    code, err = _run_cli(argv, out, capfd, case.subprocess)
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert "Traceback" not in err and "internal error" not in err
    for word in case.words:
        assert word in lines[0], lines[0]
    assert _snapshot(out) == before


def test_the_corpus_is_large():
    assert len(CASES) >= 100
    assert sum(c.subprocess for c in CASES) >= 5


# ----------------------------------------------------------------- legal but odd: exit 0


def _odd_pair(g, w, make):
    left, right = make(g.left_arr), make(g.right_arr)
    return _write(w / "l.png", left), _write(w / "r.png", right)


ODD = {
    "png16": lambda a: _png(a.astype(np.uint16) * 257, 0),
    "rgba": lambda a: _png(np.dstack([a, a, a, np.full_like(a, 255)]), 6),
    "rgba16": lambda a: _png(np.dstack([a, a, a, np.full_like(a, 255)]).astype(np.uint16) * 257, 6),
    "grey-alpha": lambda a: _png(np.dstack([a, np.full_like(a, 200)]), 4),
    "grey-alpha16": lambda a: _png(np.dstack([a, a]).astype(np.uint16) * 257, 4),
}


@pytest.mark.parametrize("kind", sorted(ODD))
def test_odd_but_legal_images_run(kind, good, tmp_path, capfd):
    left, right = _odd_pair(good, tmp_path, ODD[kind])
    code, err = _run_cli(
        _recon(left, right, good.calib, "--json", tmp_path / "r.json"), tmp_path, capfd, False
    )
    assert code == 0, err
    assert json.loads((tmp_path / "r.json").read_text())["version"] == 1


def test_one_pixel_high_image_with_its_calibration_runs(good, tmp_path, capfd):
    left = _write(tmp_path / "l.png", cv2.imencode(".png", good.left_arr[:1])[1].tobytes())
    right = _write(tmp_path / "r.png", cv2.imencode(".png", good.right_arr[:1])[1].tobytes())
    calib = tmp_path / "c.yaml"
    write_opencv_yaml(_calib(W, 1), calib)
    code, err = _run_cli(_recon(left, right, calib, "--json", tmp_path / "r.json"), tmp_path, capfd, False)
    assert code == 0, err
    assert json.loads((tmp_path / "r.json").read_text())["obstacle"] == "none"
    code, err = _run_cli(
        ["disparity", left, right, "--calib", calib, "--out", tmp_path / "d.pfm"], tmp_path, capfd, False
    )
    assert code == 0, err


def test_opencv_yaml_whose_comment_mentions_cam0_is_opencv(good, tmp_path, capfd):
    calib = _write(tmp_path / "c.yaml", _yaml().replace("---\n", "---\n# cam0 = left, baseline = 80 mm\n"))
    code, err = _run_cli(_recon(good.left, good.right, calib), tmp_path, capfd, False)
    assert code == 0, err


def test_replay_with_a_time_jump_of_decades_does_not_wait(good, tmp_path, capfd, caplog):
    rec = tmp_path / "rec"
    rec.mkdir()
    for i in range(2):
        cv2.imwrite(str(rec / f"l{i}.png"), good.left_arr)
        cv2.imwrite(str(rec / f"r{i}.png"), good.right_arr)
    _write(rec / "pairs.csv", CSV_HEAD + "0,0,0,l0.png,r0.png\n1,1e9,1e9,l1.png,r1.png\n")
    code, err = _run_cli(
        ["replay", rec, "--calib", good.calib, "--no-lcm", "--speed", "100"], tmp_path, capfd, False
    )
    assert code == 0, err
    assert "replayed as" in caplog.text  # the cap is said (a warning on stderr)


def test_missing_extras_are_named_before_any_work(good, tmp_path, capfd, monkeypatch):
    """The base install (no matplotlib, no lcm): each command names the extra up front."""
    for name in list(sys.modules):
        if name == "matplotlib" or name.startswith(("matplotlib.", "stereo_terrain.viz")) or name == "lcm":
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "lcm", None)
    cases = [
        (["demo", "--out", tmp_path / "demo"], "stereo-terrain[viz]"),
        (["simulate", "--out", tmp_path / "sim"], "stereo-terrain[viz]"),
        (_recon(good.left, good.right, good.calib, "--plot", tmp_path / "p.png"), "stereo-terrain[viz]"),
        (["replay", good.rec], "stereo-terrain[lcm]"),
        (["run", "--left", "0", "--right", "1", "--calib", good.calib], "stereo-terrain[lcm]"),
        (
            ["simulate", "--out", tmp_path / "sim", "--no-plot", "--lcm-url", "udpm://x"],
            "stereo-terrain[lcm]",
        ),
    ]
    for argv, extra in cases:
        code, err = _run_cli(argv, tmp_path, capfd, False)
        assert code == 2 and extra in err and err.count("\n") == 1, err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_an_lcm_url_liblcm_refuses_is_one_line(good, tmp_path, capfd):
    """liblcm prints its own "Error: LCM provider ... not found" on the terminal before it
    fails; that goes into the command's one line instead."""
    pytest.importorskip("lcm", reason="the lcm extra is not installed")
    code, err = _run_cli(["replay", good.rec, "--as-fast", "--lcm-url", "bogus://x"], tmp_path, capfd, False)
    assert code == 2 and err.count("\n") == 1, err
    assert "cannot open LCM" in err and "bogus" in err
