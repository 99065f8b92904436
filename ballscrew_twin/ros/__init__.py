"""ROS 2 glue of ballscrew_twin: the only subpackage that imports rclpy.

Modules:
    inputs          -- validation and unit conversion of commanded inputs (pure Python, no rclpy)
    twin_node       -- :class:`TwinNode`, publishes ``ballscrew_twin_msgs/DragTorque``
    demo_commander  -- command publisher and torque printer used by ``make demo``

Topics carry SI units (REP 103) except ``sensor_msgs/Temperature``, which is in degrees
Celsius by its own convention and is converted to kelvin at the node's edge.
"""
