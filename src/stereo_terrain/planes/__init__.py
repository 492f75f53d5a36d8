"""Stage 4: decomposition of the point cloud into planes (MSAC).

``orientation`` (the paper's orientation method, 3.2.2), ``contour`` (the contour method,
3.2.1, with the image ordering rules), ``auto`` (the union of both), ``_kernels`` (compiled
inner loops). The estimator itself lives below the stages in ``stereo_terrain.msac``, since
the planar fill of stage 2 uses it too. The grid subsample with local normals they work on
comes from ``cloud``.
"""
