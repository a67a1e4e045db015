"""Every FORTE node's parameters as ROS serves them: ``python tools/parameter_descriptors.py``.

Constructs each node in this process (no configure, no hardware), lists its parameters and
prints one JSON object: node -> parameter -> default value, type, description, read-only
flag, ranges and additional constraints, exactly as ``ros2 param describe`` would show them.
Run it before and after a change to the parameter tables and ``diff`` the outputs: a change
that should not touch what users see must print the same bytes.

``--before-split`` imports the nodes from their module paths before the package split of
0.2.0 (for a checkout of 0.1.0 on ``PYTHONPATH``).
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
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
    'bench_twin': ('forte_sim.ros.bench_twin_node', 'BenchTwinNode'),
    'forte_commission': ('forte_commissioning.ros.commission_node', 'CommissionNode'),
    'force_calibration': ('forte_commissioning.ros.force_calibration_node', 'ForceCalibrationNode'),
    'slip_lift': ('forte_commissioning.ros.slip_lift_node', 'SlipLiftNode'),
    'visualization': ('forte_bringup.visualization_node', 'VisualizationNode'),
}
#: The nodes that moved when the lab's procedures became forte_commissioning (0.2.0), at their
#: module paths before (``--before-split``, for a checkout of 0.1.0 on ``PYTHONPATH``).
BEFORE_SPLIT = {
    'forte_commission': 'forte_bringup.commission_node',
    'force_calibration': 'forte_bringup.calibrate_force',
    'slip_lift': 'forte_bringup.slip_lift_node',
}


#: Parameters that must be given for a node to start: node -> name -> value (None: the
#: path of an empty bag); they print as '<given>'.
REQUIRED = {'bag_replay': {'bag_path': None}, 'slip_lift': {'grip_angle': 0.535}}
#: Constructor arguments beside the parameters: node -> keyword arguments.
ARGUMENTS = {'forte_commission': {'steps': [], 'headless': True}}


def describe(node, overridden: dict) -> dict[str, dict]:
    """name -> what ``describe_parameters`` and ``get_parameters`` answer for it."""
    names = sorted(node._parameters)  # every declared parameter, use_sim_time included
    out = {}
    for name, descriptor in zip(names, node.describe_parameters(names)):
        out[name] = {
            'value': '<given>' if name in overridden else node.get_parameter(name).value,
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
    parser.add_argument('--before-split', action='store_true',
                        help='module paths of 0.1.0, before forte_commissioning')
    args = parser.parse_args(argv)
    isolate_ros_network()
    import rclpy
    from rclpy.parameter import Parameter

    from forte_driver.replay.bags import BagWriter

    rclpy.init()
    result = {}
    with tempfile.TemporaryDirectory() as folder:
        here = os.getcwd()
        os.chdir(folder)  # what a node makes in its working folder (a calibration session)
        empty_bag = Path(folder) / 'empty'
        with BagWriter(empty_bag):
            pass
        try:
            for name, (module, cls) in NODES.items():
                module = BEFORE_SPLIT.get(name, module) if args.before_split else module
                required = REQUIRED.get(name, {})
                overrides = [Parameter(key, value=str(empty_bag) if value is None else value)
                             for key, value in required.items()]
                node = getattr(importlib.import_module(module), cls)(
                    parameter_overrides=overrides, **ARGUMENTS.get(name, {}))
                try:
                    result[name] = describe(node, required)
                finally:
                    node.destroy_node()
        finally:
            rclpy.shutdown()
            os.chdir(here)
    json.dump(result, sys.stdout, indent=1, sort_keys=True, default=list)
    print()
    return 0


if __name__ == '__main__':
    sys.exit(main())
