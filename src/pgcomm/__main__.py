"""``python -m pgcomm``: the same command line as the ``pgcomm`` console script."""

import sys

from pgcomm.cli import main

sys.exit(main())
