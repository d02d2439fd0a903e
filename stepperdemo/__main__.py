"""``python -m stepperdemo`` works like the ``stepperdemo`` entry point."""

import sys

from .front.cli import main

sys.exit(main())
