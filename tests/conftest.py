"""What every test module shares: the environment the command's output is read in."""

import os

# pytest-xdist's workers inherit COLUMNS=80 and LINES=24 from their launcher; the tests read the
# command's output as a user piping it would (no COLUMNS: the command's own width for a pipe)
os.environ.pop("COLUMNS", None)
os.environ.pop("LINES", None)
