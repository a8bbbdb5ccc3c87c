"""``python -m verification [--quick] [--report PATH]``: see :mod:`verification.cli`."""

import sys

from .cli import main

sys.exit(main())
