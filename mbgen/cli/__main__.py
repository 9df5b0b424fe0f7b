"""``python -m mbgen.cli``: the same as ``mbgen``."""

import sys

from . import main

sys.exit(main())
