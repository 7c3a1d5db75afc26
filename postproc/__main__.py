"""`python -m postproc ...` runs the command-line interface, as the `postproc` script does."""

from postproc.cli import main

if __name__ == "__main__":
    main()
