"""ROS 2 glue of ballscrew_twin: the only subpackage that imports rclpy.

Modules:
    inputs          -- validation and unit conversion of commanded inputs (pure Python, no rclpy)
    scheduler       -- fixed-step tick schedule of the node (pure Python, no rclpy)
    tick_thread     -- the thread that runs the node's ticks on wall time (no rclpy)
    cdr             -- CDR bytes of DragTorque / ContactStateArray, published as they are
    fidelity        -- the models the node can run, chosen by its ``fidelity`` parameter
    diagnostics     -- ``/diagnostics`` messages of the node
    executors       -- the executors the processes spin with, and a ``spin_once`` loop
    twin_node       -- :class:`TwinNode`: commands in, DragTorque and ContactStateArray out
    node_command    -- ``ballscrew-twin node``
    launcher        -- ``ballscrew-twin launch FILE``: several nodes, stopped cleanly on Ctrl-C
    demo_commander  -- command script of ``make demo``
    console_view    -- console view and plot of ``make demo``
    replay, record  -- ``ballscrew-twin replay BAG`` / ``record``: bags without ros2 bag
    health_node     -- the health monitor node: bench data against the twin, fault verdicts

Topics carry SI units (REP 103) except ``sensor_msgs/Temperature``, which is in degrees
Celsius by its own convention and is converted to kelvin at the node's edge.
"""
