"""The FORTE gripper alone under ros2_control: its controller manager and controllers.

    ros2 launch forte_description gripper_control.launch.py                 # mock hardware
    ros2 launch forte_description gripper_control.launch.py use_mock_hardware:=false \\
        joint_state_broadcaster:=false                                      # the real gripper

Starts robot_state_publisher with ``urdf/forte_gripper.urdf.xacro`` and its ros2_control tag
(``ros2_control:=true``; ``use_mock_hardware``, ``initial_position``), the controller manager
(``ros2_control_node``, which reads the tag from ``/robot_description``) with
``config/forte_controllers.yaml``, and spawns ``forte_gripper_controller`` (action
``/forte_gripper_controller/gripper_cmd``, control_msgs/action/ParallelGripperCommand) and,
with ``joint_state_broadcaster:=true``, ``joint_state_broadcaster``.

Real path (``use_mock_hardware:=false``): FORTE's gripper driver must run and be active (e.g.
``ros2 launch forte_bringup hardware.launch.py``, whose robot_state_publisher is off by
default): topic_based_ros2_control publishes the commands on ``/gripper/joint_commands`` and
reads ``/joint_states``, which the driver publishes itself; leave the broadcaster out there
(it would publish the hardware's state back onto the topic the hardware reads).

Needs ros2_control (controller_manager, hardware_interface's mock components,
joint_state_broadcaster, parallel_gripper_controller, and topic_based_ros2_control for the
real path), deliberately not dependencies of forte_description (docs/moveit.md).
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import Command, LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

SHARE = FindPackageShare('forte_description')

#: Every argument: name, default, description.
ARGUMENTS = (
    ('use_mock_hardware', 'true',
     'true: mock_components/GenericSystem (no gripper); false: the gripper driver through '
     'topic_based_ros2_control'),
    ('initial_position', '0.0', 'initial theta of the finger joints [rad] (0 = closed)'),
    ('joint_state_broadcaster', 'true',
     "spawn joint_state_broadcaster (false on the real path: the driver publishes "
     "/joint_states)"),
    ('controllers_file', PathJoinSubstitution([SHARE, 'config', 'forte_controllers.yaml']),
     "the controller manager's parameter file"),
)


def generate_launch_description() -> LaunchDescription:
    xacro_file = PathJoinSubstitution([SHARE, 'urdf', 'forte_gripper.urdf.xacro'])
    description = ParameterValue(
        Command(['xacro ', xacro_file, ' ros2_control:=true use_mock_hardware:=',
                 LaunchConfiguration('use_mock_hardware'), ' initial_position:=',
                 LaunchConfiguration('initial_position')]),
        value_type=str)
    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=default, description=text)
          for name, default, text in ARGUMENTS),
        Node(package='robot_state_publisher', executable='robot_state_publisher',
             parameters=[{'robot_description': description}], output='screen'),
        Node(package='controller_manager', executable='ros2_control_node',
             parameters=[LaunchConfiguration('controllers_file')], output='screen'),
        Node(package='controller_manager', executable='spawner',
             arguments=['forte_gripper_controller'], output='screen'),
        Node(package='controller_manager', executable='spawner',
             arguments=['joint_state_broadcaster'], output='screen',
             condition=IfCondition(LaunchConfiguration('joint_state_broadcaster'))),
    ])
