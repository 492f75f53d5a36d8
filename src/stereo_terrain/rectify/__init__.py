"""Stage 1: load and check a stereo pair, rectify it from the calibration.

Rectification uses OpenCV (``stereoRectify`` for the rotations, ``initUndistortRectifyMap``
for the maps); the maps are computed once per calibration and cached in a
:class:`Rectification`. Already rectified calibrations (Middlebury, OAK-D) pass images
through untouched.

What the rectified view keeps (``fov``, :data:`RECTIFY_FOVS`):

- ``keep``: OpenCV ``alpha = 0``'s rectified cameras (same focal length, so no loss of
  resolution or depth accuracy against ``valid``), moved by a whole number of pixels in
  ``cx, cy`` into a *larger* rectified image that holds the raw left image's whole outline
  (its four edges, corners included): every raw left pixel lands inside the rectified
  left image, so the floor and the first riser in the raw bottom strip are kept. The
  right camera's outline is not added: a rectified right pixel outside the left's rows
  or columns is never matched by a left pixel (``x_right = x_left - d``, same row).
  ``valid``'s image is an exact crop of ``keep``'s (same pixels). The image grows by at
  most :data:`_KEEP_MAX_MARGIN` of the raw size on each side; the added pixels that have
  no source are marked in ``valid_left/valid_right``. Costs: 16-24 % more rectified
  pixels on the renderer's scenes (default / realistic profile), about that much more
  time for matching and remapping. :attr:`Rectification.image_size` is the rectified size,
  :attr:`Rectification.raw_size` the raw one; :func:`rectify` checks the raw images
  against the latter. The view's top and bottom edges are then rows in which both
  images' source pixels start and end, bowed across the width, not the image's first
  and last rows: the terrain stage takes them from ``GridSample.source_rows`` (a wall
  cut by that top edge is not a riser whose top was seen).
  Not the default yet: on 30 rendered default scenes it keeps 96% of the raw bottom tenth
  (``valid`` 79%; the rest is the :data:`SOURCE_MARGIN_PX` margin at the raw border) with
  lower rise errors (p90 0.5 cm vs 0.7 cm) but one staircase fewer with the right step
  count (78% vs 81%), and the acceptance mix of ``tests/test_pipeline.py`` falls to 77%
  (17/22; bound 85%, ``valid`` 86%): both 320x240 scenes lose a step or the staircase
  (``benchmarks/bench_rectify_accuracy.py``).
- ``full-height`` (opt-in, ``PipelineConfig(rectify_fov="full-height")``): the rectified
  camera is chosen so that the raw images' whole vertical extent stays in view. Its focal
  length ``f`` (the same for x and y, so pixels are square whatever
  ``fy / fx`` the raw cameras have) and ``cy`` put the raw top
  and bottom edges of *both* cameras, over the central half of the width, on the first and
  last rectified rows; ``cx`` centres the left camera's raw horizontal extent. The output
  keeps the raw size. A level camera close to stairs sees the floor and the first riser
  only in a thin strip at the bottom of the raw image: OpenCV's ``alpha = 0`` crops to
  a rectangle in which both images have a source pixel, and that rectangle, held to the
  image's aspect ratio, loses that strip whenever the images are offset or turned
  against each other. The price is a slightly smaller focal length and pixels without a
  source (image corners, the sides when ``fy < fx``). On the renderer's scenes (whose
  floor is never a thin strip) it keeps 94% of the raw bottom tenth instead of 77%, at a
  focal length 6% shorter, which costs a little (step count 81% -> 78% on 30 scenes,
  ``benchmarks/bench_rectify_accuracy.py``); so it is not the default yet.
- ``valid`` (the default): OpenCV ``alpha = 0`` (every rectified pixel has a source).
- ``all``: OpenCV ``alpha = 1`` (every raw pixel is kept; the smallest focal length).

Pixels without a source pixel are not left to the matchers: :attr:`Rectification.valid_left`
and :attr:`Rectification.valid_right` mark the rectified pixels that have one (with a margin
of :data:`SOURCE_MARGIN_PX` so that no matching window reaches the black border), and the
disparity backends make every disparity NaN whose left pixel or matched right pixel is
outside them.

The package's files: ``rectification.py`` (:class:`Rectification`,
:func:`compute_rectification`, :func:`rectify_points`), ``pair.py`` (:func:`rectify`,
:class:`RectifiedPair`) and ``images.py`` (:func:`read_image`, :func:`write_image`,
:func:`to_grey`, :func:`check_pair`).
"""

from .images import MAX_IMAGE_PIXELS, check_pair, check_same_size, read_image, to_grey, write_image
from .pair import RectifiedPair, rectify
from .rectification import (
    RECTIFY_FOVS,
    SOURCE_MARGIN_PX,
    Rectification,
    compute_rectification,
    rectify_points,
    valid_interior,
)

__all__ = [
    "MAX_IMAGE_PIXELS",
    "RECTIFY_FOVS",
    "SOURCE_MARGIN_PX",
    "Rectification",
    "RectifiedPair",
    "check_pair",
    "check_same_size",
    "compute_rectification",
    "read_image",
    "rectify",
    "rectify_points",
    "to_grey",
    "valid_interior",
    "write_image",
]
