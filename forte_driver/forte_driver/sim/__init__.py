"""Simulated FORTE scenes: gripper, fin-ray fingers, pressure sensor, objects, arm lift.

Pure core (no rclpy) in every module but :mod:`.sim_node`, the ROS shell. Quick start::

    from forte_driver.sim import make_scene, OBJECTS
    scene = make_scene('grasp', object_name='raspberry', seed=0)
    frames, truth = scene.step(20, servo_command_rad=scene.initial_angle, arm_velocity_z=0.0)

See docs/simulation.md for the model, its parameters and its cost.
"""
from .catalogue import CATEGORIES, INDENTORS, OBJECTS, IndentorSpec, ObjectSpec, objects_in_category
from .model import CHANNEL_NAMES, DEFAULT_MODEL, QUANTUM, SAMPLE_PERIOD, SAMPLE_RATE, GripperModel
from .scene import SCENE_NAMES, SLIP_CHARACTERIZATION_OBJECTS, Scene, make_scene
from .state import TICK_SAMPLES
from .truth import (
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
    'CATEGORIES', 'CHANNEL_NAMES', 'DEFAULT_MODEL', 'INDENTORS', 'OBJECTS', 'OBJECT_BROKEN',
    'OBJECT_CRUSHED', 'OBJECT_DROPPED', 'OBJECT_HELD', 'OBJECT_NONE', 'OBJECT_RESTING',
    'QUANTUM', 'SAMPLE_PERIOD', 'SAMPLE_RATE', 'SCENE_NAMES', 'SLIP_CHARACTERIZATION_OBJECTS',
    'SLIP_GROSS', 'SLIP_INCIPIENT', 'SLIP_NONE', 'SLIP_ROTATIONAL', 'SLIP_STICK_SLIP',
    'TICK_SAMPLES', 'GripperModel', 'IndentorSpec', 'ObjectSpec', 'Scene', 'SceneTruth',
    'make_scene', 'objects_in_category',
]
