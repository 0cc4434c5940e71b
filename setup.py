from glob import glob

from setuptools import find_packages, setup

package_name = "torquefree_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*", "tools"]),
    package_data={"torquefree_ros.bench": ["hard_cases.json"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/config/scenes", glob("config/scenes/*.yaml")),
    ],
    install_requires=["setuptools"],
    # mujoco 4.0.0 on PyPI is a shell around the not-yet-usable mujoco-core; 3.x is the real one
    extras_require={"plot": ["matplotlib>=3.7"], "bench": ["matplotlib>=3.7", "mujoco>=3.1,<4"]},
    zip_safe=True,
    maintainer="torquefree_ros maintainers",
    maintainer_email="maintainers@torquefree-ros.invalid",
    description="Exact torque-free rigid-body attitude simulator for ROS 2",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "torquefree_sim = torquefree_ros.sim_node:main",
            "torquefree_propagate = torquefree_ros.cli:propagate_main",
            "torquefree_bag = torquefree_ros.bag_cli:bag_main",
            "torquefree_record = torquefree_ros.recorder:main",
            "torquefree_play = torquefree_ros.player:main",
            "torquefree_plot = torquefree_ros.plot:main",
            "torquefree_bench = torquefree_ros.bench.cli:main",
        ],
    },
)
