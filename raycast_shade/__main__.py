"""``python -m raycast_shade``: the same as the ``raycast-shade`` command."""

from .apps.cli import main

raise SystemExit(main())
