"""`python -m motivml.ros2 --fds ASKING,HEARING --namespace NS`: the run's ROS 2 bridge process (see bridge.py)."""

import os
import sys

if os.environ.get("COVERAGE_PROCESS_START"):  # the test suite measures the bridge too
    import coverage

    coverage.process_startup()

from .bridge import main

sys.exit(main())
