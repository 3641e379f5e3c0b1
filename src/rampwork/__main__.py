"""``python -m rampwork``: the command line (see :mod:`rampwork.cli`)."""

import sys

from rampwork.cli import main

if __name__ == "__main__":
    sys.exit(main())
