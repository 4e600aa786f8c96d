"""``python -m cumuli`` runs the ``cumuli`` command."""

import sys

from cumuli.cli import main

sys.exit(main())
