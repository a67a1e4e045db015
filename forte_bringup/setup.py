"""Build script of the forte_bringup ament_python package (colcon and pip)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'forte_bringup'


def share(pattern: str) -> list[str]:
    """Files matching ``pattern`` (relative to this folder), for data_files."""
    return sorted(glob(pattern, recursive=True))


setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', share('config/*.yaml')),
        ('share/' + package_name + '/launch', share('launch/*.py')),
        ('share/' + package_name + '/urdf', share('urdf/*')),
        ('share/' + package_name + '/meshes', share('meshes/*')),
        ('share/' + package_name + '/rviz', share('rviz/*.rviz')),
        ('share/' + package_name + '/plotjuggler', share('plotjuggler/*.xml')),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='FORTE maintainers',
    maintainer_email='maintainers@forte-gripper.org',
    description=(
        'FORTE launch files (hardware, simulation, bag replay), parameter files, '
        'bag recording, the demo and the evaluation harness.'
    ),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'forte_bringup = forte_bringup.bringup:main',
            'forte_record = forte_bringup.record:main',
            'forte_demo = forte_bringup.demo:main',
            'forte_evaluate = forte_bringup.evaluate:main',
            'forte_commission = forte_bringup.commission_node:main',
            'forte_calibrate_force = forte_bringup.calibrate_force:main',
            'forte_slip_lift = forte_bringup.slip_lift_node:main',
            'forte_visualization = forte_bringup.visualization_node:main',
        ],
    },
)
