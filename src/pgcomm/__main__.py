"""``python -m pgcomm``: the same command line as the ``pgcomm`` console script."""

from pgcomm.cli import entry

if __name__ == "__main__":  # importing the module (autodoc does) must not run the program
    entry()
