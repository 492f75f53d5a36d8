"""Hypothesis fuzzing of every reader and of the config dataclasses (issue 12): whatever the
file or value, the only exceptions are the package's own."""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stereo_terrain.bench import read_truth
from stereo_terrain.calibrate import parse_pattern
from stereo_terrain.calibration import (
    read_calibration,
    read_middlebury_calib,
    read_opencv_yaml,
    read_stereodemo_json,
)
from stereo_terrain.errors import ConfigError, InputError, StereoTerrainError
from stereo_terrain.frames import load_rig
from stereo_terrain.pipeline import PipelineConfig
from stereo_terrain.rectify import read_image
from stereo_terrain.runtime.capture import read_pairs_index
from stereo_terrain.runtime.simulate import ApproachConfig, _approach_json, load_approach
from stereo_terrain.stereo.io import read_pfm
from stereo_terrain.swing import SwingConfig

FUZZ = settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))

_YAML_BITS = [
    "%YAML:1.0\n---\n", "K1: ", "!!opencv-matrix\n", "   rows: 3\n   cols: 3\n   dt: d\n   data: ",
    "[", "]", "{", "}", ", ", "\n", "image_width: ", "image_height: ", "T: ", "R: ", "D1: ", ".inf", ".nan",
    "1e300", "-1", "0", "64", "48", "54.4", "abc", "- ", ": ", "# cam0 baseline\n", "<?xml version=\"1.0\"?>",
    "<opencv_storage>", "</opencv_storage>", "<K1>", "</K1>", "cam0=", "baseline=", "width=", "height=",
    "ndisp=", "doffs=", "\"fx\": ", "\"width\": ", "NaN", "Infinity", "true", "null", "\xe9", "\x00",
    "\"obstacle\": ", "\"stairs\"", "\"steps\": ", "\"rise\": ", "\"approach\": ", "\"swing\": ",
    "\"image_size\": ", "\"stair_rise_m\": ", "\"nominal_height_m\": ", "\"",
]  # fmt: skip

text_like = st.one_of(
    st.lists(st.sampled_from(_YAML_BITS), max_size=40).map("".join).map(lambda t: t.encode("utf-8")),
    st.binary(max_size=400),
    st.text(max_size=200).map(lambda t: t.encode("utf-8", errors="surrogatepass")),
)


#: Where the fuzzed files go: one folder for the module, removed after it (hundreds of
#: examples each left a folder in /tmp before).
_ROOT: list[Path] = []


@pytest.fixture(scope="module", autouse=True)
def _fuzz_root():
    with tempfile.TemporaryDirectory(prefix="fuzz-") as root:
        _ROOT.append(Path(root))
        yield
        _ROOT.pop()


def _file(data: bytes, name: str) -> Path:
    d = Path(tempfile.mkdtemp(dir=_ROOT[-1]))
    p = d / name
    p.write_bytes(data)
    return p


def _approach_folder(path: Path):
    """:func:`load_approach` of the folder holding ``path`` (it reads ``approach.json``)."""
    return load_approach(path.parent)


def _only_own_errors(fn, *args) -> None:
    try:
        fn(*args)
    except StereoTerrainError:
        pass


@pytest.mark.parametrize(
    "reader, name",
    [
        (read_calibration, "calib.yaml"),
        (read_calibration, "calib.txt"),
        (read_calibration, "calib.json"),
        (read_opencv_yaml, "calib.yaml"),
        (read_opencv_yaml, "calib.xml"),
        (read_middlebury_calib, "calib.txt"),
        (read_stereodemo_json, "calib.json"),
        (load_rig, "rig.yaml"),
        (PipelineConfig.from_yaml, "config.yaml"),
        (read_pfm, "disp.pfm"),
        (read_image, "image.png"),
        (read_image, "image.jpg"),
        (read_truth, "truth.json"),
        (_approach_folder, "approach.json"),
    ],
    ids=lambda v: getattr(v, "__qualname__", v),
)
@FUZZ
@given(data=text_like)
def test_readers_raise_only_their_own_errors(reader, name, data):
    _only_own_errors(reader, _file(data, name))


@pytest.mark.parametrize("reader, name", [(read_truth, "truth.json"), (_approach_folder, "approach.json")])
def test_deeply_nested_json_is_refused_before_the_parser(reader, name):
    """Python's JSON parser recurses: brackets nested 100000 deep ended in a
    ``RecursionError`` (a traceback from ``bench`` or ``replay``) before the nesting check."""
    with pytest.raises(InputError, match="nests brackets deeper"):
        reader(_file(("[" * 100000 + "]" * 100000).encode(), name))


@FUZZ
@given(cfg=st.fixed_dictionaries({"image_size": st.tuples(st.integers(32, 2000), st.integers(32, 2000))}))
def test_approach_file_round_trips(cfg):
    """What ``simulate`` writes, :func:`load_approach` reads back unchanged."""
    approach, swing = ApproachConfig(**cfg), SwingConfig()
    folder = _file(_approach_json(approach, swing).encode(), "approach.json").parent
    assert load_approach(folder) == (approach, swing)


@FUZZ
@given(text=st.one_of(st.text(max_size=12), st.tuples(st.integers(-5, 99), st.integers(-5, 99)).map(
    lambda t: f"{t[0]}x{t[1]}")))  # fmt: skip
def test_board_pattern_text(text):
    """``--pattern``: two integers, or the package's own error naming the text."""
    try:
        cols, rows = parse_pattern(text)
    except StereoTerrainError as exc:
        assert repr(text)[1:-1] in str(exc) or text in str(exc)
        return
    assert isinstance(cols, int) and isinstance(rows, int)
    assert f"{cols}x{rows}" == "x".join(str(int(v)) for v in text.lower().split("x"))


def test_file_names_that_are_not_utf8(tmp_path):
    """OpenCV's imread, imwrite and FileStorage crashed the process (a segfault, no message)
    on a file name that is not UTF-8, which Python hands over as a str with surrogate
    escapes. The readers and writers go through Python's own file calls instead."""
    import os

    from stereo_terrain.calibration import write_opencv_yaml
    from stereo_terrain.rectify import write_image
    from stereo_terrain.synthetic import default_scene_spec, render_scene

    folder = Path(os.fsdecode(os.fsencode(str(tmp_path)) + b"/caf\xe9"))
    try:
        folder.mkdir()
    except (OSError, UnicodeError):
        pytest.skip("this file system takes only UTF-8 names")
    scene = render_scene(default_scene_spec())
    image = folder / "l\udce9.png"
    write_image(image, scene.left)
    assert np.array_equal(read_image(image), scene.left)
    calib = folder / "c\udce9.yaml"
    write_opencv_yaml(scene.calibration, calib)
    back = read_calibration(calib)
    assert back.image_size == scene.calibration.image_size and np.allclose(back.K1, scene.calibration.K1)
    xml = folder / "c\udce9.xml"
    write_opencv_yaml(scene.calibration, xml)
    assert xml.read_text().startswith("<?xml") and np.allclose(read_calibration(xml).T, scene.calibration.T)


_PFM_HEADERS = st.tuples(
    st.sampled_from([b"Pf", b"PF", b"P5", b""]),
    st.one_of(st.tuples(st.integers(-10, 70), st.integers(-10, 70)).map(lambda t: f"{t[0]} {t[1]}".encode()),
              st.binary(max_size=12)),
    st.sampled_from([b"-1.0", b"1.0", b"0", b"nan", b"inf", b"x"]),
    st.binary(max_size=2000),
)  # fmt: skip


@FUZZ
@given(parts=_PFM_HEADERS)
def test_pfm_headers(parts):
    kind, dims, scale, body = parts
    _only_own_errors(read_pfm, _file(kind + b"\n" + dims + b"\n" + scale + b"\n" + body, "d.pfm"))


@FUZZ
@given(
    arr=st.tuples(st.integers(1, 20), st.integers(1, 20), st.sampled_from([1, 3, 4])),
    ext=st.sampled_from([".png", ".jpg", ".tiff", ".bmp"]),
    cut=st.floats(0.0, 1.0),
    depth=st.sampled_from([np.uint8, np.uint16]),
)
def test_images_cut_anywhere(arr, ext, cut, depth):
    h, w, c = arr
    img = np.random.default_rng(h * w).integers(0, 200, (h, w, c)).astype(depth)
    ok, buf = cv2.imencode(ext, img if ext != ".jpg" else img.astype(np.uint8))
    assert ok
    data = buf.tobytes()
    _only_own_errors(read_image, _file(data[: int(len(data) * cut)], "i" + ext))


_CSV_BITS = ["index,t_left,t_right,left,right", "x,y,z,roll,pitch,yaw", "\n", ",", "0", "1.5", "-1", "nan",
             "inf", "1e300", "l0.png", "r0.png", "", "\"", "\x00", "\xe9", "a"]  # fmt: skip


@FUZZ
@given(data=st.one_of(st.lists(st.sampled_from(_CSV_BITS), max_size=40).map(lambda b: "".join(b).encode()),
                      st.binary(max_size=300)))  # fmt: skip
def test_pairs_csv(data):
    folder = _file(data, "pairs.csv").parent
    _only_own_errors(read_pairs_index, folder)


# ----------------------------------------------------------------- config dataclasses


def _config_classes():
    from stereo_terrain.calibrate import BoardConfig
    from stereo_terrain.runtime.loop import LoopConfig
    from stereo_terrain.runtime.simulate import ApproachConfig
    from stereo_terrain.swing import TriggerConfig

    classes = [PipelineConfig, LoopConfig, ApproachConfig, TriggerConfig, BoardConfig]
    defaults = PipelineConfig()
    classes += [type(getattr(defaults, f.name)) for f in dataclasses.fields(PipelineConfig)]
    return sorted({c for c in classes if dataclasses.is_dataclass(c)}, key=lambda c: c.__name__)


values = st.one_of(
    st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=8), st.lists(st.integers(-5, 5), max_size=4), st.tuples(st.integers(), st.integers()),
)  # fmt: skip


@pytest.mark.parametrize("cls", _config_classes(), ids=lambda c: c.__name__)
@FUZZ
@given(data=st.data())
def test_config_dataclasses_raise_only_their_own_errors(cls, data):
    fields = [f.name for f in dataclasses.fields(cls)]
    required = [
        f.name
        for f in dataclasses.fields(cls)
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    chosen = data.draw(st.lists(st.sampled_from(fields), max_size=3, unique=True)) if fields else []
    kwargs = {name: data.draw(values) for name in {*chosen, *required}}
    _only_own_errors(lambda: cls(**kwargs))


@FUZZ
@given(data=st.dictionaries(st.sampled_from(["sgbm", "sgm", "cloud", "swing", "method", "min_depth_m",
                                             "max_disparity_px", "drift", "bogus"]),
                            st.one_of(values, st.dictionaries(st.text(max_size=12), values, max_size=3)),
                            max_size=3))  # fmt: skip
def test_pipeline_config_from_dict(data):
    _only_own_errors(PipelineConfig.from_dict, data)


@pytest.mark.parametrize(
    "data, field",
    [
        ({"orientation": {"seed": -1}}, "seed"),
        ({"fill": {"seed": -3}}, "seed"),
        ({"terrain": {"disparity_sigma_px": 1e300}}, "disparity_sigma_px"),
        ({"gravity": {"correlation_px": 1e300}}, "correlation_px"),
        ({"cloud": {"max_depth_m": 1e300}}, "max_depth_m"),
        ({"fill": {"smooth_sigma_px": 1e4}}, "smooth_sigma_px"),
        ({"tracking": {"drift_fraction": 1e8}}, "drift_fraction"),
        ({"tracking": {"yaw_drift_rad_per_m": 10.0}}, "yaw_drift_rad_per_m"),
    ],
)
def test_config_values_that_crashed_a_stage_are_refused(data, field):
    """Values the type checks let through and a stage then tripped on (a negative seed for
    NumPy's generator, overflows at 1e300, a singular tracking filter, a Gaussian wider
    than any image that asked for memory without end): refused when the config is built,
    naming the field."""
    with pytest.raises(ConfigError, match=field):
        PipelineConfig.from_dict(data)
    assert PipelineConfig.from_dict({next(iter(data)): {}})  # the section's defaults are fine


def test_values_that_read_as_something_else_are_refused(tmp_path):
    """JSON ``true`` is no focal length (Python reads it as 1.0); a ground truth with no
    known pixel scored every matcher 0% bad; ``max_disparity_px: -1`` was refused by the
    backend, in a message that did not name the config file."""
    import json

    from stereo_terrain.evaluation import read_middlebury_scene
    from stereo_terrain.stereo.io import write_pfm

    good = {"fx": 450.0, "fy": 450.0, "cx0": 320.0, "cx1": 320.0, "cy": 240.0, "baseline_meters": 0.075,
            "width": 64, "height": 48}  # fmt: skip
    path = tmp_path / "stereodemo_calibration.json"
    path.write_text(json.dumps(good))
    assert read_calibration(path).image_size == (64, 48)
    path.write_text(json.dumps({**good, "fx": True}))
    with pytest.raises(InputError, match="non-numeric"):
        read_calibration(path)
    scene = tmp_path / "scene"
    scene.mkdir()
    (scene / "calib.txt").write_text(
        "cam0=[100 0 32; 0 100 24; 0 0 1]\ncam1=[100 0 32; 0 100 24; 0 0 1]\ndoffs=0\nbaseline=100\n"
        "width=64\nheight=48\nndisp=32\n"
    )
    for name in ("im0.png", "im1.png"):
        cv2.imwrite(str(scene / name), np.full((48, 64), 128, np.uint8))
    write_pfm(scene / "disp0GT.pfm", np.full((48, 64), np.nan, np.float32))
    with pytest.raises(InputError, match="no known disparity"):
        read_middlebury_scene(scene)
    config = tmp_path / "config.yaml"
    config.write_text("max_disparity_px: -1\n")
    with pytest.raises(ConfigError, match="config.yaml.*max_disparity_px must be positive"):
        PipelineConfig.from_yaml(config)


def test_inputs_that_are_no_regular_file_are_named(tmp_path):
    """A pipe (``<(...)``, a FIFO: one without a writer blocked the read for ever) and a
    link round in a loop read as "not found"; each is now named for what it is."""
    import os

    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs on this system")
    fifo = tmp_path / "rig.yaml"
    os.mkfifo(fifo)
    loop = tmp_path / "loop.yaml"
    loop.symlink_to(loop)
    for reader in (load_rig, read_calibration, read_image, PipelineConfig.from_yaml):
        with pytest.raises(InputError, match="not a regular file"):
            reader(fifo)
        with pytest.raises(InputError, match="leads to no file"):
            reader(loop)
        with pytest.raises(InputError, match="not found"):
            reader(tmp_path / "missing.yaml")
