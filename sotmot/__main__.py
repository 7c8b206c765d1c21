"""``python -m sotmot`` is the ``sotmot`` command."""

import sys

from sotmot.cli import main

sys.exit(main())
