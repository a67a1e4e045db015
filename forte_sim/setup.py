"""Build script of the forte_sim ament_python package (colcon and pip)."""
from glob import glob

from setuptools import find_packages, setup

package_name = 'forte_sim'


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
    description=(
        'The FORTE simulator (gripper, fin-ray fingers, pressure sensor, objects, arm lift, '
        'ground truth, calibration rig), its node, and the bench twin that couples the scene '
        'to the driver\'s emulated devices.'
    ),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'sim_node = forte_sim.ros.sim_node:main',
            'bench_twin_node = forte_sim.ros.bench_twin_node:main',
            'forte_sim_dataset = forte_sim.dataset_tool:main',
        ],
    },
)
