"""Stage 4: decomposition of the point cloud into planes (MSAC).

``msac`` (generic and vectorised plane MSAC), ``normals`` (grid subsample + local
normals), ``orientation`` (the paper's orientation method, 3.2.2).
"""
