"""Show the FORTE gripper on its own in RViz, its finger joints on sliders.

    ros2 launch forte_description view_gripper.launch.py
    ros2 launch forte_description view_gripper.launch.py prefix:=right_ gui:=false

Starts robot_state_publisher with the expanded ``urdf/forte_gripper.urdf.xacro`` (argument
``prefix``), joint_state_publisher_gui (``gui:=true``, default) or joint_state_publisher, and
RViz with ``rviz/view_gripper.rviz`` (``rviz:=false`` leaves it out). The right finger
joint is a mimic of the left in the URDF: joint_state_publisher(_gui) gives the left finger
a slider and moves the right one with it.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import Command, LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare

#: Every argument: name, default, description.
ARGUMENTS = (
    ('prefix', '', 'prepended to every link and joint name of the gripper, e.g. right_'),
    ('gui', 'true', 'true: joint_state_publisher_gui (sliders); false: joint_state_publisher'),
    ('rviz', 'true', 'start RViz with the view of rviz_config'),
    ('rviz_config', PathJoinSubstitution([FindPackageShare('forte_description'), 'rviz',
                                          'view_gripper.rviz']),
     'RViz configuration file'),
)


def generate_launch_description() -> LaunchDescription:
    xacro_file = PathJoinSubstitution([FindPackageShare('forte_description'), 'urdf',
                                       'forte_gripper.urdf.xacro'])
    description = ParameterValue(
        Command(['xacro ', xacro_file, ' prefix:=', LaunchConfiguration('prefix')]),
        value_type=str)
    gui = LaunchConfiguration('gui')
    return LaunchDescription([
        *(DeclareLaunchArgument(name, default_value=default, description=text)
          for name, default, text in ARGUMENTS),
        Node(package='robot_state_publisher', executable='robot_state_publisher',
             parameters=[{'robot_description': description}], output='screen'),
        Node(package='joint_state_publisher_gui', executable='joint_state_publisher_gui',
             condition=IfCondition(gui)),
        Node(package='joint_state_publisher', executable='joint_state_publisher',
             condition=UnlessCondition(gui)),
        Node(package='rviz2', executable='rviz2', arguments=['-d', LaunchConfiguration(
            'rviz_config')], condition=IfCondition(LaunchConfiguration('rviz'))),
    ])
