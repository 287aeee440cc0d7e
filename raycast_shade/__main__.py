"""``python -m raycast_shade``: the same as the ``raycast-shade`` command."""

from .cli import main

raise SystemExit(main())
