"""ballscrew_twin: a real-time digital twin of a preloaded double-nut ball screw.

Subpackages:
    physics  -- pure, vectorised physical laws (geometry, Hertz, lubrication, friction)
    models   -- state and solving: catalogue formulas, steady-state equilibrium
    ros      -- ROS 2 nodes (thin glue; the only place that imports rclpy)

All quantities are SI inside the package (m, N, Pa, s, rad, K).
"""

__version__ = "0.1.0"
