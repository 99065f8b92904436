"""Test-wide set-up: keep DDS on this machine before anything imports rclpy, and choose the
hypothesis profile.

``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` keeps discovery on loopback, and a ROS domain of
this run's own (1..100, from the PID) keeps parallel runs apart. Values the user (or the
Makefile) already set are respected. This module is imported by pytest before any test module,
hence before rclpy is imported or initialised.

Hypothesis: with ``CI=true`` (set by CI services and by ``.ci/run``'s callers) the ``ci`` profile
is loaded: examples derived from each test's name (derandomize) and no example database, so a
CI run is the same every time and never replays examples a previous run saved in
``.hypothesis/``. Local runs keep the default profile: fresh random examples each run, and the
failures found are saved and replayed first until fixed.
"""

from __future__ import annotations

import os

from hypothesis import settings

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 100 + 1))

settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI", "").lower() == "true" else "default")
