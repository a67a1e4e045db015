"""Build script of the forte_ros ament_python package (colcon and pip)."""
from setuptools import find_packages, setup

package_name = 'forte_ros'

setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='FORTE maintainers',
    maintainer_email='maintainers@forte-gripper.org',
    description=(
        'What every FORTE package shares: the sensor contract and the parameter-table shape '
        '(pure Python); node runner, lifecycle base, QoS, diagnostics, parameters and test '
        'helpers for the ROS shells.'
    ),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
)
