"""The Python API refuses the wrong kind of argument with a message saying what to pass
(found in review: each gave an AttributeError deep inside)."""

import numpy as np
import pytest

from stereo_terrain.errors import ConfigError, InputError
from stereo_terrain.pipeline import Pipeline, PipelineConfig
from stereo_terrain.synthetic import default_scene_spec, render_scene
from stereo_terrain.tracking import StairTracker


@pytest.fixture(scope="module")
def scene():
    return render_scene(default_scene_spec())


def test_pipeline_arguments_of_the_wrong_kind(scene):
    with pytest.raises(InputError, match="read_calibration"):
        Pipeline("calib.yaml")
    with pytest.raises(InputError, match="load_rig"):
        Pipeline(scene.calibration, "rig.yaml")
    with pytest.raises(ConfigError, match="from_dict"):
        Pipeline(scene.calibration, scene.rig, {"method": "auto"})
    pipeline = Pipeline(scene.calibration, scene.rig, warm_up=False)
    with pytest.raises(InputError, match="load_rig"):
        pipeline.set_rig({"T_body_camera": np.eye(4).tolist()})


def test_a_nested_config_given_as_a_mapping_is_refused():
    with pytest.raises(ConfigError, match="swing must be a SwingConfig"):
        PipelineConfig(swing={"buffer_m": 0.1})
    assert PipelineConfig.from_dict({"swing": {"buffer_m": 0.1}}).swing.buffer_m == 0.1


def test_set_rig_none_goes_back_to_gravity_from_the_scene(scene):
    pipeline = Pipeline(scene.calibration, scene.rig, warm_up=False)
    assert pipeline.run(scene.left, scene.right).gravity_source == "rig"
    pipeline.set_rig(None)
    assert pipeline.run(scene.left, scene.right).gravity_source == "scene"


def test_the_tracker_takes_the_terrain_not_the_result(scene):
    result = Pipeline(scene.calibration, scene.rig, warm_up=False).run(scene.left, scene.right)
    with pytest.raises(InputError, match=r"\.terrain"):
        StairTracker().update(result, None, 0.0)
    assert StairTracker().update(result.terrain, None, 0.0).state == "tentative"
