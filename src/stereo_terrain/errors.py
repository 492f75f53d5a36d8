"""The package's exceptions.

User mistakes (a missing file, a malformed calibration, images of the wrong size) raise
subclasses of :class:`InputError`, which itself subclasses :class:`ValueError`. The CLI
turns every :class:`StereoTerrainError` into one line on stderr and exit code 2.
Expected failures of an estimator (no stairs in view, a degenerate sample) are *results*,
never exceptions.
"""

from __future__ import annotations


class StereoTerrainError(Exception):
    """Base class of every error this package raises on purpose."""


class InputError(StereoTerrainError, ValueError):
    """An argument, file or image is not what the API expects."""


class CalibrationError(InputError):
    """A calibration file or object is malformed, non-finite or inconsistent."""


class FrameError(InputError):
    """Transforms whose frames do not chain, or a transform that is not rigid."""


class ConfigError(InputError):
    """A configuration value is out of its documented range."""
