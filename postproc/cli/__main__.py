"""`python -m postproc.cli ...` runs the command-line interface, as the `postproc` script does."""

import sys

from . import main

if __name__ == "__main__":
    sys.exit(main())
