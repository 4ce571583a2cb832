"""``python -m vibra``: the ``vibra`` command."""

import sys

from vibra.cli import main

sys.exit(main())
