"""Running the command line in-process, as the CLI tests do."""

from __future__ import annotations

from stereo_terrain.cli import main


def run_cli(argv, capsys, entry=main) -> tuple[int, str, str]:
    """``stereo-terrain ARGV`` in this process (or another command's ``entry``, its
    ``main``): exit code (argparse's usage errors too), stdout and stderr."""
    try:
        code = entry([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err
