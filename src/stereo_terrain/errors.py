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


#: Exit codes of every command (docs/conventions.md): success, internal error, bad input.
EXIT_OK, EXIT_INTERNAL, EXIT_USAGE = 0, 1, 2


def exit_code(exc: BaseException) -> int:
    """The one mapping from an exception to a command's exit code.

    The package's own errors (bad input, config, calibration, frames), and an operating
    system refusal about a named file (permission denied, disk full, a folder where a
    file was expected), are the user's to fix: :data:`EXIT_USAGE`. Anything else is a bug:
    :data:`EXIT_INTERNAL`. Ctrl-C gives 130 as shells expect.
    """
    if isinstance(exc, KeyboardInterrupt):
        return 130
    if isinstance(exc, StereoTerrainError):
        return EXIT_USAGE
    if isinstance(exc, OSError) and getattr(exc, "filename", None) is not None:
        return EXIT_USAGE
    return EXIT_INTERNAL
