"""``python -m pliant.cli``: the ``pliant`` command."""

import sys

from pliant.cli import main

sys.exit(main())
