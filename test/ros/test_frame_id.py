"""One ``header.frame_id`` for the screw in every message and bag the project writes: the one
definition (units.SCREW_FRAME_ID) is the default of both nodes, in their code and their YAML;
the writers put it in their headers (test/models/test_simulation.py, test/bags)."""

from __future__ import annotations

from pathlib import Path

import yaml

from ballscrew_twin import results
from ballscrew_twin.bags import bench_writer
from ballscrew_twin.ros.health_parameters import HEALTH_PARAMETERS
from ballscrew_twin.ros.twin_parameters import TWIN_PARAMETERS
from ballscrew_twin.units import SCREW_FRAME_ID

CONFIG = Path(__file__).resolve().parents[2] / "config"


def _node_parameters(name: str) -> dict[str, object]:
    data = yaml.safe_load((CONFIG / name).read_text(encoding="utf-8"))
    (params,) = (v["ros__parameters"] for v in data.values())
    return dict(params)


def test_every_writer_names_the_screw_frame_alike() -> None:
    assert SCREW_FRAME_ID == "screw"
    for table in (TWIN_PARAMETERS, HEALTH_PARAMETERS):
        (spec,) = (p for p in table if p.name == "frame_id")
        assert spec.default == SCREW_FRAME_ID
    assert _node_parameters("twin_node.yaml")["frame_id"] == SCREW_FRAME_ID
    assert _node_parameters("health_node.yaml")["frame_id"] == SCREW_FRAME_ID
    # the writers keep no copy of their own (their headers: test_simulation, test_bench_bags)
    assert not hasattr(results, "FRAME_ID") and not hasattr(bench_writer, "FRAME_ID")
