"""ament_python packaging of ballscrew_twin (also installable with plain ``pip install -e .``)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE_NAME = "ballscrew_twin"

setup(
    name=PACKAGE_NAME,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    # Tabulated maps of the real-time model travel with the package.
    package_data={PACKAGE_NAME: ["data/*.npz", "data/*.json"]},
    # Installed by `setup.py install` / colcon and by a regular `pip install .`. A PEP 660
    # editable install (`pip install -e .`, what tools/setup_env.sh runs) does not copy them;
    # the package then reads config/ from the source tree (ballscrew_twin.params).
    data_files=[
        # ament index marker: makes the package discoverable by ament_index / ros2 tools.
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE_NAME}"]),
        (f"share/{PACKAGE_NAME}", ["package.xml"]),
        (f"share/{PACKAGE_NAME}/config", sorted(glob("config/*.yaml"))),
        *[
            (f"share/{PACKAGE_NAME}/config/{sub}", sorted(glob(f"config/{sub}/*.yaml")))
            for sub in ("scenarios", "scenes", "bench_scenes", "launch")
        ],
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="ballscrew_twin developers",
    maintainer_email="dev@ballscrew-twin.invalid",
    description=(
        "Real-time digital twin of a preloaded double-nut ball screw "
        "(drag torque, per-ball contact states) for test benches and PHM."
    ),
    license="Apache-2.0",
    python_requires=">=3.11",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "twin_node = ballscrew_twin.ros.twin_node:main",
            "health_node = ballscrew_twin.ros.health_node:main",
            "twin_demo_commander = ballscrew_twin.ros.demo_commander:main",
            "ballscrew-twin = ballscrew_twin.cli:main",
        ],
    },
)
