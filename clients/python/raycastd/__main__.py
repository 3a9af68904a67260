"""`python3 -m raycastd …`: the command line (raycastd.cli)."""

import sys

from raycastd.cli import main

sys.exit(main())
