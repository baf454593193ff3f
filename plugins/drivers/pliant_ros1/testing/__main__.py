"""``python -m pliant_ros1.testing ROBOT ...``: run a robot peer (see :mod:`pliant_ros1.testing.peer`)."""

import sys

from pliant_ros1.testing.command import main

sys.exit(main())
