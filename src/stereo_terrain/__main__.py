"""``python -m stereo_terrain``: the command line (:mod:`stereo_terrain.cli`)."""

from .cli import main

if __name__ == "__main__":
    raise SystemExit(main())
