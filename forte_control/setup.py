"""Build script of the forte_control ament_python package (colcon and pip)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'forte_control'


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
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='FORTE maintainers',
    maintainer_email='maintainers@forte-gripper.org',
    description=('FORTE grasp state machine (FORTE, W/o-Slip and On-Off controllers) as a '
                 'pure library, and the control node serving the Grasp action with a '
                 'safety watchdog.'),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'grasp_controller_node = forte_control.ros.grasp_controller_node:main',
        ],
    },
)
