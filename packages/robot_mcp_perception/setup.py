"""setuptools entry for colcon's ament_python build (system ROS 2 users).

The uv workspace installs this package from pyproject.toml with hatchling; colcon runs this
file instead. Both install the same Python package; this one also installs the ament index
marker, package.xml, the launch file and the Hydra config tree under share/.
"""

from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = "robot_mcp_perception"
HERE = Path(__file__).resolve().parent


def tree(directory: str) -> list[tuple[str, list[str]]]:
    """data_files entries that reproduce ``directory`` under share/<package>/."""
    entries = []
    for folder in [
        *sorted(p for p in (HERE / directory).rglob("*") if p.is_dir()),
        HERE / directory,
    ]:
        files = sorted(str(f.relative_to(HERE)) for f in folder.iterdir() if f.is_file())
        if files:
            entries.append((f"share/{PACKAGE}/{folder.relative_to(HERE)}", files))
    return entries


setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages("src"),
    package_dir={"": "src"},
    include_package_data=False,
    # config/ is linked into the package (Hydra reads it from there at run time).
    package_data={PACKAGE: ["py.typed", "config/*.yaml", "config/*/*.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/launch", ["launch/vision.launch.py"]),
        *tree("config"),
    ],
    zip_safe=False,
    entry_points={"console_scripts": [f"vision_node = {PACKAGE}.vision_node:main"]},
)
