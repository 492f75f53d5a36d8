import numpy as np
import pytest

from stereo_terrain.calibration import (
    StereoCalibration,
    read_calibration,
    read_middlebury_calib,
    write_opencv_yaml,
)
from stereo_terrain.errors import CalibrationError, InputError


def _calib(**kw):
    base = dict(
        K1=np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
        D1=np.array([-0.1, 0.01, 0, 0, 0]),
        K2=np.array([[502.0, 0, 318], [0, 502, 242], [0, 0, 1]]),
        D2=np.array([-0.09, 0.01, 0, 0, 0]),
        R=np.eye(3),
        T=np.array([-0.08, 0.0, 0.0]),
        image_size=(640, 480),
    )
    base.update(kw)
    return StereoCalibration(**base)


def test_yaml_round_trip(tmp_path):
    c = _calib()
    write_opencv_yaml(c, tmp_path / "calib.yaml")
    back = read_calibration(tmp_path / "calib.yaml")
    for k in ("K1", "D1", "K2", "D2", "R", "T"):
        assert np.allclose(getattr(back, k), getattr(c, k)), k
    assert back.image_size == (640, 480)
    assert not back.rectified
    assert np.isclose(back.baseline_m, 0.08)


@pytest.mark.parametrize("name", ["calib.txt", "calib_source.txt"])
def test_middlebury_both_spacings(shared_data, name):
    c = read_middlebury_calib(shared_data / "middlebury2014Q" / "Piano" / name)
    assert c.rectified and c.image_size == (707, 481) and c.ndisp == 65
    assert np.isclose(c.K1[0, 0], 713.189) and np.isclose(c.K2[0, 2] - c.K1[0, 2], 31.34, atol=0.01)
    assert np.isclose(c.baseline_m, 0.178089)


def test_all_middlebury_and_oakd_files_read(shared_data):
    files = list((shared_data / "middlebury2014Q").glob("*/calib*.txt"))
    files += list(shared_data.glob("oakd_lite/*/stereodemo_calibration.json"))
    files += [shared_data / "middlebury2014Q_noGT" / "Classroom2" / "calib.txt"]
    assert len(files) >= 19
    for f in files:
        c = read_calibration(f)
        assert c.rectified and c.baseline_m > 0.05


def test_oakd_json(shared_data):
    c = read_calibration(shared_data / "oakd_lite" / "desk" / "stereodemo_calibration.json")
    assert np.isclose(c.K1[0, 0], 451.03, atol=0.01) and np.isclose(c.baseline_m, 0.075)


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(K1=np.full((3, 3), np.nan)), "non-finite"),
        (dict(K1=np.eye(2)), "shape"),
        (dict(D1=np.zeros(3)), "distortion"),
        (dict(R=np.diag([1.0, 1.0, -1.0])), "rotation"),
        (dict(T=np.zeros(3)), "baseline"),
        (dict(image_size=(0, 480)), "positive"),
        (dict(K2=np.array([[-5.0, 0, 1], [0, 5, 1], [0, 0, 1]])), "camera matrix"),
    ],
)
def test_bad_calibration_values(kw, match):
    with pytest.raises(CalibrationError, match=match):
        _calib(**kw)


def test_bad_calibration_files(tmp_path):
    with pytest.raises(InputError, match="not found"):
        read_calibration(tmp_path / "missing.yaml")
    p = tmp_path / "c.yaml"
    p.write_text(
        "%YAML:1.0\n---\nK1: !!opencv-matrix\n  rows: 3\n  cols: 3\n  dt: d\n"
        "  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
    )
    with pytest.raises(CalibrationError, match="lacks 'D1'"):
        read_calibration(p)
    p.write_text("this is : not [ a calibration")
    with pytest.raises(CalibrationError):
        read_calibration(p)
    m = tmp_path / "calib.txt"
    m.write_text("cam0=[1 0 0; 0 1 0]\ncam1=[1 0 0; 0 1 0; 0 0 1]\nbaseline=100\nwidth=10\nheight=10\n")
    with pytest.raises(CalibrationError, match="9 numbers"):
        read_calibration(m)
    j = tmp_path / "c.json"
    j.write_text('{"fx": 1}')
    with pytest.raises(CalibrationError, match="lacks"):
        read_calibration(j)
