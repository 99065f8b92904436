"""Console view of the demo: health shown when published, "n/a" otherwise; summary and plot
(per-nut split, rejected commands marked, units); its and the demo commander's --duration."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from ballscrew_twin_msgs.msg import DragTorque, HealthResidual
from conftest import SavedFigures
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.executors import SingleThreadedExecutor

from ballscrew_twin.ros import console_view, demo_commander
from ballscrew_twin.ros.console_view import ConsoleView


def _torque(sec: int, total: float) -> DragTorque:
    msg = DragTorque(
        total=total,
        nut_master=0.4 * total,
        nut_slave=0.6 * total,
        screw_speed=10.47,
        temperature=20.0,
        preload=1500.0,
        fidelity="catalog-zhou",
    )
    msg.header.stamp.sec = sec
    return msg


def _input_status(sec: int, rejected: int, reason: str) -> DiagnosticArray:
    msg = DiagnosticArray()
    msg.header.stamp.sec = sec
    values = [
        KeyValue(key="rejected", value=str(rejected)),
        KeyValue(key="last rejection", value=reason),
    ]
    level = bytes([1 if rejected else 0])
    msg.status = [
        DiagnosticStatus(name="twin: input preload", level=level, values=values),
        DiagnosticStatus(name="twin: real time", level=bytes([0])),
    ]
    return msg


def test_health_summary_and_plot(
    executor: SingleThreadedExecutor, tmp_path: Path, saved_figures: SavedFigures
) -> None:
    view = ConsoleView(context=executor.context)
    executor.add_node(view)
    assert view.health_text() == "n/a"
    assert "no drag_torque" in view.summary()
    for sec, total in ((100, 0.02), (101, 0.04)):
        view._on_torque(_torque(sec, total))
    view._on_diagnostics(_input_status(100, 0, ""))
    view._on_diagnostics(_input_status(101, 1, "preload nan is not finite"))
    view._on_diagnostics(_input_status(102, 1, "preload nan is not finite"))  # no new one
    assert [(r.time, r.channel, r.count) for r in view.rejections] == [(1.0, "preload", 1)]
    view._on_health(HealthResidual(verdict=HealthResidual.WARN, normalized_residual=2.5))
    assert view.health_text().startswith("WARN")
    summary = view.summary()
    assert "2 drag_torque messages over 1.00 s" in summary
    assert "20.000 .. 40.000 mN m" in summary and "1 command(s) rejected" in summary
    view.print_status()  # prints, must not fail
    png = view.plot(tmp_path / "plot.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert saved_figures.missing_units() == []
    torque_ax = saved_figures.saved[0][0].axes[0]
    lines = {line.get_label(): line for line in torque_ax.lines}
    np.testing.assert_allclose(lines["master nut"].get_ydata(), [8.0, 16.0])
    np.testing.assert_allclose(lines["slave nut"].get_ydata(), [12.0, 24.0])
    marks = [list(line.get_xdata()) for line in torque_ax.lines if line.get_color() == "r"]
    assert [1.0, 1.0] in marks  # the rejection, at the diagnostic that reported it
    assert "rejected: preload nan" in torque_ax.texts[0].get_text()


@pytest.mark.parametrize("main", [console_view.main, demo_commander.main])
@pytest.mark.parametrize(
    ("duration", "words"),
    [
        ("0", "--duration = 0.0 is outside the allowed range (0, inf] s"),
        ("-3", "--duration = -3.0 is outside the allowed range (0, inf] s (must not be negative)"),
        ("nan", "--duration: nan is not a finite number (allowed range (0, inf] s)"),
    ],
)
def test_a_duration_not_above_zero_is_refused_naming_it(
    main: Callable[[list[str] | None], None],
    duration: str,
    words: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["program", "--duration", duration])
    assert exit_.value.code == 2
    assert words in capsys.readouterr().err
