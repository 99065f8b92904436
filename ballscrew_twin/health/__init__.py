"""Health monitoring of a ball screw against its twin: bench data in and out, faults, detection.

Modules:
    bags            -- robust reader of recorded bench bags (mcap or sqlite3) into SI series
    sensors         -- sensor models of a test bench (torque meter, encoder, thermometer, load cell)
    fault_profiles  -- faults injected in the twin: classes, onset, growth, defect frequencies
    bench_scene     -- bench scene files (operating profile, sensors, faults), validated
    bench_data      -- ``ballscrew-twin bench-data``: generate recorded bench bags from the twin
    residuals       -- the twin's prediction at the measured operating point, residuals
    tracker         -- Kalman filter of slow drifts (sensor bias, friction scale, preload)
    detectors       -- CUSUM, chi-square and order-tracked spectral tests, thresholds
    classify        -- likely fault class from the twin's fault responses and defect orders
    monitor         -- the pipeline shared by the health node and ``detect``
    detect          -- ``ballscrew-twin detect BAG``: offline verdict, plots, JSON

Nothing here imports rclpy; the ROS side (replay, record, the health node) is in
:mod:`ballscrew_twin.ros`.
"""
