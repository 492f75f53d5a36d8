"""stereo-terrain: stairs and boxes for a legged robot from two cheap webcams.

Pipeline (one module per stage, data flowing one way)::

    calibration -> rectify -> stereo (SGM) -> cloud -> planes -> terrain -> swing
                                                                    \\-> pipeline -> cli

Importing the package does no work; submodules are imported on use.
"""

__version__ = "0.1.0"
