"""Build script of the forte_commissioning ament_python package (colcon and pip)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'forte_commissioning'

setup(
    name=package_name,
    version='0.2.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/launch', sorted(glob('launch/*.py'))),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='FORTE maintainers',
    maintainer_email='maintainers@forte-gripper.org',
    description=(
        'Putting a FORTE gripper into service: sensor commissioning, force calibration with '
        'a load cell, slip characterisation and threshold tuning, with their nodes and '
        'launch files.'
    ),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'forte_commission = forte_commissioning.ros.commission_node:main',
            'forte_calibrate_force = forte_commissioning.ros.force_calibration_node:main',
            'forte_slip_lift = forte_commissioning.ros.slip_lift_node:main',
            'forte_tune_slip = forte_commissioning.tune_slip:main',
        ],
    },
)
