"""Commands whose inputs are checked against the validity envelope before the module that does
the work runs (docs/model.md section 13): ``bench-data generate`` (the scene's operating
profile) is refused outside the envelope with one line naming the file. Arguments and
everything else are those of the wrapped module. (``calibrate`` checks its targets itself.)
"""

from __future__ import annotations

import argparse
from types import SimpleNamespace

from .health import bench_data
from .health.bench_scene import load_bench_scene
from .models.base import OperatingPoint
from .models.validity import ValidityEnvelope, refuse_outside
from .params import load_config


def run_bench_data(args: argparse.Namespace) -> int:
    """``bench-data``: for ``generate``, refuse a profile that leaves the envelope first."""
    if args.action == "generate":
        scene = load_bench_scene(args.scene)
        envelope = ValidityEnvelope.for_config(load_config(scene.config_path()))
        corners = [
            OperatingPoint(screw_speed=p.speed, temperature=p.temperature, preload=p.preload)
            for p in scene.profile
        ]
        refuse_outside(corners, envelope, scene.source or str(args.scene))
    return int(bench_data.run(args))


#: The commands as :mod:`ballscrew_twin.cli` wires them (``add_arguments`` and ``run``).
bench_data_command = SimpleNamespace(add_arguments=bench_data.add_arguments, run=run_bench_data)
