"""The ``ballscrew-twin`` commands: one module per command, named after it.

Each module has ``add_arguments(parser)`` (its options) and ``run(args)`` (returns the exit
status) and is wired by :mod:`ballscrew_twin.cli`; the work is done by the modules below this
layer (models, health monitor, scenes, report, calibration, bags), which parse no arguments.
``bench`` lives in :mod:`ballscrew_twin.benchmarks`, and ``node``, ``launch``, ``replay``,
``record`` and ``health-node`` in :mod:`ballscrew_twin.ros`.
"""
