"""Console view of the demo: health shown when published, "n/a" otherwise; summary and plot."""

from __future__ import annotations

from pathlib import Path

from ballscrew_twin_msgs.msg import DragTorque, HealthResidual
from rclpy.executors import SingleThreadedExecutor

from ballscrew_twin.ros.console_view import ConsoleView


def _torque(sec: int, total: float) -> DragTorque:
    msg = DragTorque(
        total=total, screw_speed=10.47, temperature=293.15, preload=1500.0, fidelity="catalog-zhou"
    )
    msg.header.stamp.sec = sec
    return msg


def test_health_summary_and_plot(executor: SingleThreadedExecutor, tmp_path: Path) -> None:
    view = ConsoleView(context=executor.context)
    executor.add_node(view)
    assert view.health_text() == "n/a"
    assert "no drag_torque" in view.summary()
    for sec, total in ((100, 0.02), (101, 0.04)):
        view._on_torque(_torque(sec, total))
    view._on_health(HealthResidual(verdict=HealthResidual.WARN, normalized_residual=2.5))
    assert view.health_text().startswith("WARN")
    summary = view.summary()
    assert "2 drag_torque messages over 1.00 s" in summary
    assert "20.000 .. 40.000 mN m" in summary
    view.print_status()  # prints, must not fail
    png = view.plot(tmp_path / "plot.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
