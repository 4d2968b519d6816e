"""``python -m vibdyn``: the ``vibdyn`` command (:mod:`vibdyn.faces.cli`)."""

import sys

from vibdyn.faces.cli import main

if __name__ == "__main__":
    sys.exit(main())
