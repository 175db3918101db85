"""``python -m deltacal.cli``."""

import sys

from .main import main

sys.exit(main())
