"""One ``header.frame_id`` for the screw in every message and bag the project writes."""

from __future__ import annotations

from pathlib import Path

import yaml

from ballscrew_twin import results
from ballscrew_twin.bags import bench_writer
from ballscrew_twin.ros.twin_parameters import SCREW_FRAME_ID

CONFIG = Path(__file__).resolve().parents[2] / "config"


def _node_parameters(name: str) -> dict[str, object]:
    data = yaml.safe_load((CONFIG / name).read_text(encoding="utf-8"))
    (params,) = (v["ros__parameters"] for v in data.values())
    return dict(params)


def test_every_writer_names_the_screw_frame_alike() -> None:
    assert SCREW_FRAME_ID == results.FRAME_ID == bench_writer.FRAME_ID
    assert _node_parameters("twin_node.yaml")["frame_id"] == SCREW_FRAME_ID
    assert _node_parameters("health_node.yaml")["frame_id"] == SCREW_FRAME_ID
