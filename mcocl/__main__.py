"""``python -m mcocl`` is the ``mcocl`` command."""

import sys

from .cli import main

sys.exit(main())
