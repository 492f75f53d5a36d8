"""``python -m stereo_terrain``: the command line (:mod:`stereo_terrain.cli`)."""

from .cli import main

raise SystemExit(main())
