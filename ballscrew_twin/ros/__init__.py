"""ROS 2 glue of ballscrew_twin: the only subpackage that imports rclpy.

Modules ("pure": no rclpy and no message types):
    parameters      -- ParameterSpec: a declarative parameter (type, unit, bounds, choices) (pure)
    twin_parameters -- the twin node's parameter table and input presets (pure)
    health_parameters -- the health node's parameter table (pure)
    node_parameters -- TableNode: a node declaring, checking and reading a parameter table
    inputs          -- validation and unit conversion of commanded inputs (pure)
    twin_inputs     -- the twin node's subscriptions, feeding the checks of ``inputs``
    scheduler       -- fixed-step tick schedule of the node (pure)
    tick_thread     -- the thread that runs the node's ticks on wall time (pure)
    tick_counts     -- counts of the ticks per window and since start-up (pure)
    fidelity        -- the models the node can run, chosen by its ``fidelity`` parameter (pure)
    step_down       -- when ``fidelity: auto`` steps down to a cheaper model (pure)
    twin_models     -- the model in use, its catalogue stand-in, model switches (pure)
    cdr             -- CDR bytes of DragTorque / ContactStateArray, published as they are (pure)
    twin_messages   -- the twin's messages from a model output (pure)
    diagnostics     -- ``/diagnostics`` messages from check results
    twin_diagnostics -- the twin node's checks (no rclpy)
    tables          -- the real-time tables of the node's screw, built when missing (no rclpy)
    throttle        -- at most one log line per key and interval (pure)
    executors       -- the executors the processes spin with, and a ``spin_once`` loop
    node_process    -- one node in a process until SIGINT/SIGTERM, stopped cleanly
    twin_node       -- :class:`TwinNode`: commands in, DragTorque and ContactStateArray out
    node_command    -- ``ballscrew-twin node``
    launcher        -- ``ballscrew-twin launch FILE``: several nodes, stopped cleanly on Ctrl-C
    demo_commander  -- command script of ``make demo``
    console_view    -- console view and plot of ``make demo``
    replay, record  -- ``ballscrew-twin replay BAG`` / ``record``: bags without ros2 bag
    health_diagnostics -- the health node's checks and /clock watchdog (no rclpy)
    health_node     -- the health monitor node: bench data against the twin, fault verdicts

The nodes' parameters, topics, services and diagnostics: ``docs/nodes.md``.

Topics carry SI units (REP 103) except ``sensor_msgs/Temperature``, which is in degrees
Celsius by its own convention and is converted to kelvin at the node's edge.
"""
