"""``python -m app`` is the same as ``hyst``."""

import sys

from .cli import main

sys.exit(main())
