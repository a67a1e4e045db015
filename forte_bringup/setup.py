"""Build script of the forte_bringup ament_python package (colcon and pip)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'forte_bringup'


def share(pattern: str) -> list[str]:
    """Files matching ``pattern`` (relative to this folder), for data_files."""
    return sorted(glob(pattern, recursive=True))


setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', share('config/*.yaml')),
        ('share/' + package_name + '/launch', share('launch/*.py')),
        ('share/' + package_name + '/rviz', share('rviz/*.rviz')),
        ('share/' + package_name + '/plotjuggler', share('plotjuggler/*.xml')),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='FORTE maintainers',
    maintainer_email='maintainers@forte-gripper.org',
    description=(
        'FORTE on a machine: launch files of the hardware, simulation and bag-replay graphs, '
        'their parameter files, the bare-machine runner, bag recording, RViz and '
        'PlotJuggler views, and the demo.'
    ),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'forte_bringup = forte_bringup.bringup:main',
            'forte_record = forte_bringup.bag_recorder:main',
            'forte_demo = forte_bringup.demo:main',
            'forte_visualization = forte_bringup.visualization_node:main',
        ],
    },
)
