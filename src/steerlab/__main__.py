"""`python -m steerlab` is the `steerlab` command."""

import sys

from steerlab.cli import main

sys.exit(main())
