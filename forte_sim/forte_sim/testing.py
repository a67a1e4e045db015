"""Scene-driving helpers shared by the simulator's tests (forte_driver, forte_bringup).

They read the ground truth (e.g. closing until a true finger force is reached), so they
serve tests and evaluation only, never control code.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import medfilt

from forte_ros.contract import SAMPLE_RATE
from forte_sim.scene import Scene, make_scene
from forte_sim.truth import SceneTruth


def hold(scene: Scene, seconds: float, command: float, lift_velocity: float = 0.0,
         **limits) -> tuple[np.ndarray, SceneTruth]:
    """Step a scene for ``seconds`` with fixed commands; its frames and per-sample truth.

    ``limits`` are passed on to :meth:`Scene.step` (``max_current``, ``profile_velocity``).
    """
    return scene.step(int(seconds * SAMPLE_RATE), command, lift_velocity, **limits)


def close_to_force(scene: Scene, target: float) -> float:
    """Close in 1 mrad steps until the mean true finger force reaches ``target`` [N].

    Returns the servo command reached [rad].
    """
    theta = scene.joint_position
    force = 0.0
    while force < target:
        theta -= 0.001
        _, truth = scene.step(20, theta, 0.0)
        force = truth.finger_force[-1].mean()
    return theta


def median_filtered(raw: np.ndarray, baseline: np.ndarray, kernel: int = 11) -> np.ndarray:
    """Every channel of ``raw`` minus its mean over ``baseline`` rows, median filtered.

    Parameters
    ----------
    raw : numpy.ndarray, shape (n, channels)
        Raw frames.
    baseline : numpy.ndarray, shape (m, channels)
        Frames whose per-channel mean is the tare.
    kernel : int
        Median filter length (centred, :func:`scipy.signal.medfilt`) [samples].
    """
    return np.column_stack([medfilt(raw[:, c] - baseline[:, c].mean(), kernel)
                            for c in range(raw.shape[1])])


def slip_characterization_trial(object_name: str, seed: int, lift_seconds: float = 8.0
                                ) -> tuple[Scene, np.ndarray, SceneTruth, int]:
    """Slip characterisation trial (paper Sec. IV-B): grip below theta_grasp, lift at 1 mm/s.

    1 s open and still, 2 s closed to 15 mrad inside theta_zeroF, then the lift.

    Returns
    -------
    scene : Scene
    raw : numpy.ndarray, shape (n, 6)
        Every frame of the trial.
    truth : SceneTruth
        Truth of the lift only.
    offset : int
        Row of ``raw`` where the lift starts.
    """
    scene = make_scene('slip_characterization', object_name=object_name, seed=seed)
    theta = scene.theta_zero_force - 0.015
    quiet, _ = hold(scene, 1.0, scene.initial_angle)
    settle, _ = hold(scene, 2.0, theta)
    frames, truth = hold(scene, lift_seconds, theta, 0.001)
    raw = np.vstack((quiet, settle, frames))
    offset = len(quiet) + len(settle)
    return scene, raw, truth, offset
