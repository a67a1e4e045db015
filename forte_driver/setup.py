"""Build script of the forte_driver ament_python package (colcon and pip)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'forte_driver'


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
        ('share/' + package_name + '/udev', share('udev/*.rules')),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='FORTE maintainers',
    maintainer_email='maintainers@forte-gripper.org',
    description=(
        'FORTE on real devices and bags: serial sensor driver (binary and legacy ASCII '
        'protocol), Dynamixel gripper driver, bag recording, reading and replay, and its fake '
        'hardware: an emulated sensor board and simulated XM430 servos on pseudo-terminals.'
    ),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'serial_sensor_node = forte_driver.ros.serial_sensor_node:main',
            'gripper_driver_node = forte_driver.ros.gripper_driver_node:main',
            'bag_replay_node = forte_driver.ros.bag_replay_node:main',
            'forte_emulated_sensor = forte_driver.emulators.emulated_sensor:main',
            'forte_simulated_servo = forte_driver.emulators.simulated_servo:main',
        ],
    },
)
