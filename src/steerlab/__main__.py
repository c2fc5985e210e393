"""`python -m steerlab` is the `steerlab` command."""

import sys

try:  # Ctrl-C while the command starts (its imports take seconds) ends as Ctrl-C later does
    from steerlab.cli import main
except KeyboardInterrupt:
    print("interrupted", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
