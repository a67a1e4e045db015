"""Build script of the forte_evaluation ament_python package (colcon and pip)."""
from setuptools import find_packages, setup

package_name = 'forte_evaluation'

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
        'How good is FORTE: the closed-loop grasp benchmark of the paper (simulated scene, '
        'perception, state machine), the slip data sets and their signal-level benchmark, '
        'slip metrics and delay reports.'
    ),
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            'forte_evaluate = forte_evaluation.evaluate:main',
            'forte_evaluate_slip = forte_evaluation.evaluate_slip:main',
        ],
    },
)
