"""``python -m mbgen ...``: the same command line as ``mbgen ...``."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
