"""``python -m pgcomm``: the same command line as the ``pgcomm`` console script."""

from pgcomm.cli import entry

entry()
