import sys

from pliant_ros2.testing.command import main

sys.exit(main())
