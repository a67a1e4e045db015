"""Every FORTE node's parameters as ROS serves them: ``python tools/parameter_descriptors.py``.

Constructs each node in this process (no configure, no hardware), lists its parameters and
prints one JSON object: node -> parameter -> default value, type, description, read-only
flag, ranges and additional constraints, exactly as ``ros2 param describe`` would show them.
Run it before and after a change to the parameter tables and ``diff`` the outputs: a change
that should not touch what users see must print the same bytes.

``--legacy`` imports the nodes from the module paths before the issue-25 layout (for a
checkout of an older tree on ``PYTHONPATH``).
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
import tempfile
from pathlib import Path

from forte_ros.isolation import isolate_ros_network

#: node name -> (module, class) in the current layout.
NODES = {
    'serial_sensor': ('forte_driver.ros.serial_sensor_node', 'SerialSensorNode'),
    'gripper_driver': ('forte_driver.ros.gripper_driver_node', 'GripperDriverNode'),
    'bag_replay': ('forte_driver.ros.bag_replay_node', 'BagReplayNode'),
    'sim': ('forte_sim.ros.sim_node', 'SimNode'),
    'perception': ('forte_perception.ros.perception_node', 'PerceptionNode'),
    'grasp_controller': ('forte_control.ros.grasp_controller_node', 'GraspControllerNode'),
}
#: The same nodes in the layout before issue 25.
LEGACY_MODULES = {
    'serial_sensor': 'forte_driver.serial.serial_sensor_node',
    'gripper_driver': 'forte_driver.dynamixel.gripper_driver_node',
    'bag_replay': 'forte_driver.replay.bag_replay_node',
    'sim': 'forte_driver.sim.sim_node',
    'perception': 'forte_perception.perception_node',
    'grasp_controller': 'forte_control.grasp_controller_node',
}


#: Parameters that must be given for a node to start: node -> name (value: an empty bag).
REQUIRED = {'bag_replay': 'bag_path'}


def describe(node, overridden: str | None) -> dict[str, dict]:
    """name -> what ``describe_parameters`` and ``get_parameters`` answer for it."""
    names = sorted(node._parameters)  # every declared parameter, use_sim_time included
    out = {}
    for name, descriptor in zip(names, node.describe_parameters(names)):
        out[name] = {
            'value': '<given>' if name == overridden else node.get_parameter(name).value,
            'type': descriptor.type,
            'description': descriptor.description,
            'read_only': descriptor.read_only,
            'additional_constraints': descriptor.additional_constraints,
            'dynamic_typing': descriptor.dynamic_typing,
            'floating_point_range': [(r.from_value, r.to_value, r.step)
                                     for r in descriptor.floating_point_range],
            'integer_range': [(r.from_value, r.to_value, r.step)
                              for r in descriptor.integer_range],
        }
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--legacy', action='store_true', help='pre-issue-25 module paths')
    args = parser.parse_args(argv)
    isolate_ros_network()
    import rclpy
    from rclpy.parameter import Parameter

    from forte_driver.replay.bags import BagWriter

    rclpy.init()
    result = {}
    with tempfile.TemporaryDirectory() as folder:
        empty_bag = Path(folder) / 'empty'
        with BagWriter(empty_bag):
            pass
        try:
            for name, (module, cls) in NODES.items():
                module = LEGACY_MODULES[name] if args.legacy else module
                required = REQUIRED.get(name)
                overrides = [Parameter(required, value=str(empty_bag))] if required else []
                node = getattr(importlib.import_module(module), cls)(
                    parameter_overrides=overrides)
                try:
                    result[name] = describe(node, required)
                finally:
                    node.destroy_node()
        finally:
            rclpy.shutdown()
    json.dump(result, sys.stdout, indent=1, sort_keys=True, default=list)
    print()
    return 0


if __name__ == '__main__':
    sys.exit(main())
