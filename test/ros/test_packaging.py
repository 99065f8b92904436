"""Both ROS package manifests are valid format-3 manifests with the expected dependencies."""

from __future__ import annotations

from pathlib import Path

from catkin_pkg.package import parse_package

ROOT = Path(__file__).resolve().parents[2]


def test_python_package_manifest() -> None:
    pkg = parse_package(str(ROOT / "package.xml"))
    pkg.validate()
    assert pkg.package_format == 3
    assert pkg.name == "ballscrew_twin"
    exec_deps = {d.name for d in pkg.exec_depends}
    assert exec_deps >= {
        "rclpy",
        "std_msgs",
        "sensor_msgs",
        "geometry_msgs",
        "diagnostic_msgs",
        "ballscrew_twin_msgs",
        "python3-numpy",
        "python3-scipy",
        "python3-yaml",
    }
    assert {d.name for d in pkg.test_depends} >= {"python3-pytest"}
    assert pkg.get_build_type() == "ament_python"


def test_interface_package_manifest() -> None:
    pkg = parse_package(str(ROOT / "msg_defs" / "package.xml"))
    pkg.validate()
    assert pkg.package_format == 3
    assert pkg.name == "ballscrew_twin_msgs"
    assert pkg.get_build_type() == "ament_cmake"
    assert "rosidl_interface_packages" in {g.name for g in pkg.member_of_groups}
    deps = {d.name for d in pkg.build_depends} | {d.name for d in pkg.exec_depends}
    assert {"std_msgs", "builtin_interfaces"} <= deps


def test_resource_marker_and_setup_data_files() -> None:
    assert (ROOT / "resource" / "ballscrew_twin").is_file()
    setup_py = (ROOT / "setup.py").read_text(encoding="utf-8")
    for script in ("twin_node =", "twin_demo_commander =", "ballscrew-twin ="):
        assert script in setup_py
