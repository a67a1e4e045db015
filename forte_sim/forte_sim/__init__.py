"""Simulated FORTE scenes: gripper, fin-ray fingers, pressure sensor, objects, arm lift.

Pure core (no rclpy) outside :mod:`.ros` (the node, the ROS shell); the sensor contract
(channels, sample rate, quantum) is :mod:`forte_ros.contract`. Quick start::

    from forte_sim import make_scene, OBJECTS
    scene = make_scene('grasp', object_name='raspberry', seed=0)
    frames, truth = scene.step(20, servo_command_rad=scene.initial_angle, arm_velocity_z=0.0)

See docs/simulation.md for the model, its parameters and its cost.
"""
from __future__ import annotations

import importlib
from typing import Any

#: Public name -> the module that defines it, imported on first use (PEP 562): a process
#: that needs only a bench device (the simulated servos or the emulated sensor board, one
#: started per test on the bench) then does not pay for the scene's scipy imports (~1 s).
_SOURCES = {
    **dict.fromkeys(('CATEGORIES', 'INDENTORS', 'OBJECTS', 'IndentorSpec', 'ObjectSpec',
                     'objects_in_category'), 'forte_sim.catalogue'),
    **dict.fromkeys(('DEFAULT_MODEL', 'GripperModel'), 'forte_sim.model'),
    **dict.fromkeys(('SCENE_NAMES', 'SLIP_CHARACTERIZATION_OBJECTS', 'Scene', 'make_scene'),
                    'forte_sim.scene'),
    'TICK_SAMPLES': 'forte_sim.state',
    **dict.fromkeys(('OBJECT_BROKEN', 'OBJECT_CRUSHED', 'OBJECT_DROPPED', 'OBJECT_HELD',
                     'OBJECT_NONE', 'OBJECT_RESTING', 'SLIP_GROSS', 'SLIP_INCIPIENT',
                     'SLIP_NONE', 'SLIP_ROTATIONAL', 'SLIP_STICK_SLIP', 'SceneTruth'),
                    'forte_sim.truth'),
}

__all__ = sorted(_SOURCES)


def __getattr__(name: str) -> Any:
    if name not in _SOURCES:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    value = getattr(importlib.import_module(_SOURCES[name]), name)
    globals()[name] = value  # later lookups find it without this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_SOURCES})
