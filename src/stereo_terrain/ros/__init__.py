"""ROS 2 without ROS: the terrain as ROS 2 messages in MCAP, ROS 2 bags as input.

Sits on top of :mod:`stereo_terrain.runtime` (nothing in the pipeline imports it) and needs
the ``ros`` extra (``pip install 'stereo-terrain[ros]'``: ``mcap``, ``mcap-ros2-support``,
``rosbags``), imported only when one of its modules is used.

- :mod:`.messages`: the message definitions (the standard ones from ``rosbags``' type store
  of a ROS 2 distribution, and the package's own ``stereo_terrain_msgs/msg/Terrain``, built
  from the fields of the LCM ``terrain_t``), and the messages of one processed pair.
- :mod:`.mcap_out`: :class:`~.mcap_out.McapSink`, which writes them to an MCAP file (temp
  file, renamed when closed).
- :mod:`.bag`: :class:`~.bag.BagPairs`, stereo pairs from a rosbag2 folder or an MCAP
  file, and the calibration from ``sensor_msgs/msg/CameraInfo`` topics.

Topics and frames are listed in ``docs/conventions.md`` ("ROS 2 topics and frames").
"""

from __future__ import annotations

#: Topics written by :class:`~stereo_terrain.ros.mcap_out.McapSink`.
TOPIC_CLOUD = "/stereo_terrain/cloud"
TOPIC_STAIRS = "/stereo_terrain/stairs"
TOPIC_TF = "/tf"
TOPIC_IMAGE = "/stereo_terrain/left/image_rect"
TOPIC_CAMERA_INFO = "/stereo_terrain/left/camera_info"
TOPIC_DISPARITY = "/stereo_terrain/disparity"
TOPIC_TERRAIN = "/stereo_terrain/terrain"

#: The package's own message type (schema written into every MCAP file).
TERRAIN_TYPE = "stereo_terrain_msgs/msg/Terrain"

#: ROS 2 distributions whose standard message definitions can be written.
DISTROS = ("jazzy", "humble")
DEFAULT_DISTRO = "jazzy"
