"""Both ROS package manifests are valid format-3 manifests with the expected dependencies, and
package.xml declares every third-party package that ballscrew_twin imports."""

from __future__ import annotations

import ast
import re
import sys
from collections.abc import Iterator
from pathlib import Path

import yaml
from catkin_pkg.package import parse_package

ROOT = Path(__file__).resolve().parents[2]
#: rosdep key of each imported Python distribution whose key is not its import name (ROS
#: packages are imported under their own name, the key).
PYTHON_KEYS = {
    "numpy": "python3-numpy",
    "scipy": "python3-scipy",
    "numba": "python3-numba",
    "yaml": "python3-yaml",
    "matplotlib": "python3-matplotlib",
    "tqdm": "python3-tqdm",
    "psutil": "python3-psutil",
    "rosbags": "python3-rosbags-pip",
    "filterpy": "python3-filterpy-pip",
    "distributed": "python3-distributed-pip",
    "lz4": "python3-lz4-pip",
    "backports": "python3-backports-zstd-pip",
}
#: "pkg/msg/Type" names resolved to message classes at run time (replay of a bag)
MESSAGE_TYPE = re.compile(r"^([a-z][a-z0-9_]*)/msg/[A-Za-z0-9]+$")


def third_party_imports(source: str) -> Iterator[str]:
    """Top-level names of the absolute imports (also inside functions) and of the message
    packages named as "pkg/msg/Type" strings in ``source``, less the standard library and
    ballscrew_twin itself."""
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            match = MESSAGE_TYPE.match(node.value)
            names = [match.group(1)] if match else []
        for name in names:
            top = name.split(".")[0]
            if top not in sys.stdlib_module_names and top != "ballscrew_twin":
                yield top


def package_imports() -> dict[str, Path]:
    """Each third-party top-level name ballscrew_twin uses, with one file that uses it."""
    found: dict[str, Path] = {}
    for path in sorted((ROOT / "ballscrew_twin").rglob("*.py")):
        for name in third_party_imports(path.read_text(encoding="utf-8")):
            found.setdefault(name, path.relative_to(ROOT))
    return found


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
    assert {d.name for d in pkg.test_depends} >= {
        "python3-pytest",
        "python3-pytest-xdist",
        "python3-pytest-cov",
        "python3-hypothesis",
    }
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


def test_every_third_party_import_is_a_run_dependency() -> None:
    declared = {d.name for d in parse_package(str(ROOT / "package.xml")).exec_depends}
    used = package_imports()
    missing = {
        f"{PYTHON_KEYS.get(name, name)} (imported in {path})"
        for name, path in used.items()
        if PYTHON_KEYS.get(name, name) not in declared
    }
    assert not missing, f"package.xml lacks exec_depend: {sorted(missing)}"
    # and no Python dependency is declared that nothing imports any more
    stale = {key for key in declared if key.startswith("python3-")}
    stale -= {PYTHON_KEYS.get(name, name) for name in used}
    assert not stale, f"package.xml declares unused: {sorted(stale)}"


def test_the_import_scan_sees_lazy_imports_and_message_names() -> None:
    source = (
        "import os\nfrom . import sibling\nfrom ballscrew_twin import params\n"
        "def f():\n    from distributed import Client\n    import lz4.frame\n"
        "    return 'rosgraph_msgs/msg/Clock', 'not/a/type'\n"
    )
    assert sorted(third_party_imports(source)) == ["distributed", "lz4", "rosgraph_msgs"]


def test_pip_keys_are_defined_in_the_shipped_rosdep_file() -> None:
    """Keys absent from the ROS rosdep database are defined (as pip installs) in rosdep/."""
    defined = yaml.safe_load((ROOT / "rosdep" / "ballscrew_twin.yaml").read_text("utf-8"))
    declared = {d.name for d in parse_package(str(ROOT / "package.xml")).exec_depends}
    own = {"python3-distributed-pip", "python3-lz4-pip", "python3-backports-zstd-pip"}
    assert own <= declared
    assert set(defined) == own
    for key in own:
        packages = defined[key]["*"]["pip"]["packages"]
        assert len(packages) == 1 and packages[0] in (ROOT / "requirements.txt").read_text()


def test_license_file_is_the_declared_licence() -> None:
    declared = {str(x) for x in parse_package(str(ROOT / "package.xml")).licenses}
    assert declared == {"Apache-2.0"}
    assert 'license="Apache-2.0"' in (ROOT / "setup.py").read_text(encoding="utf-8")
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "Apache License" in text and "Version 2.0, January 2004" in text
    assert "END OF TERMS AND CONDITIONS" in text
