"""Simulated FORTE scenes: gripper, fin-ray fingers, pressure sensor, objects, arm lift.

Pure core (no rclpy) outside :mod:`.ros` (the node, the ROS shell); the sensor contract
(channels, sample rate, quantum) is :mod:`forte_ros.contract`. Quick start::

    from forte_sim import make_scene, OBJECTS
    scene = make_scene('grasp', object_name='raspberry', seed=0)
    frames, truth = scene.step(20, servo_command_rad=scene.initial_angle, arm_velocity_z=0.0)

See docs/simulation.md for the model, its parameters and its cost.
"""
from forte_sim.catalogue import (
    CATEGORIES,
    INDENTORS,
    OBJECTS,
    IndentorSpec,
    ObjectSpec,
    objects_in_category,
)
from forte_sim.model import DEFAULT_MODEL, GripperModel
from forte_sim.scene import SCENE_NAMES, SLIP_CHARACTERIZATION_OBJECTS, Scene, make_scene
from forte_sim.state import TICK_SAMPLES
from forte_sim.truth import (
    OBJECT_BROKEN,
    OBJECT_CRUSHED,
    OBJECT_DROPPED,
    OBJECT_HELD,
    OBJECT_NONE,
    OBJECT_RESTING,
    SLIP_GROSS,
    SLIP_INCIPIENT,
    SLIP_NONE,
    SLIP_ROTATIONAL,
    SLIP_STICK_SLIP,
    SceneTruth,
)

__all__ = [
    'CATEGORIES', 'DEFAULT_MODEL', 'INDENTORS', 'OBJECTS', 'OBJECT_BROKEN',
    'OBJECT_CRUSHED', 'OBJECT_DROPPED', 'OBJECT_HELD', 'OBJECT_NONE', 'OBJECT_RESTING',
    'SCENE_NAMES', 'SLIP_CHARACTERIZATION_OBJECTS',
    'SLIP_GROSS', 'SLIP_INCIPIENT', 'SLIP_NONE', 'SLIP_ROTATIONAL', 'SLIP_STICK_SLIP',
    'TICK_SAMPLES', 'GripperModel', 'IndentorSpec', 'ObjectSpec', 'Scene', 'SceneTruth',
    'make_scene', 'objects_in_category',
]
