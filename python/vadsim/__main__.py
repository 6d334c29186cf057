"""``python -m vadsim``: the same as the ``vadsim`` command."""

import sys

from vadsim.cli import main

sys.exit(main())
