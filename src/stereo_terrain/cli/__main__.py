"""``python -m stereo_terrain.cli``: the same as the ``stereo-terrain`` command."""

from . import main

raise SystemExit(main())
