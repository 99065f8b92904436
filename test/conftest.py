"""Test-wide set-up: keep DDS on this machine before anything imports rclpy.

``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` keeps discovery on loopback, and a ROS domain of
this run's own (1..100, from the PID) keeps parallel runs apart. Values the user (or the
Makefile) already set are respected. This module is imported by pytest before any test module,
hence before rclpy is imported or initialised.
"""

from __future__ import annotations

import os

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 100 + 1))
