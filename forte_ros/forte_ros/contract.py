"""The sensor contract of docs/contracts.md, declared once for every package.

Pure Python (no rclpy): the pure cores, the simulator, the bench devices, the offline tools
and the nodes all import these names instead of writing them again.

Channels are in contract order: index ``c`` of every ``(n, 6)`` frame array, every
``TactileFrames.data`` row and every per-channel field is :data:`CHANNEL_NAMES` ``[c]``.
"""
from __future__ import annotations

#: The six differential pressure channels, in contract order (docs/contracts.md).
CHANNEL_NAMES = ('left_distal', 'left_middle', 'left_root',
                 'right_distal', 'right_middle', 'right_root')
#: Number of channels.
N_CHANNELS = len(CHANNEL_NAMES)
#: Fingers, in contract order (finger index 0 = left, 1 = right).
FINGER_NAMES = ('left', 'right')
#: Channel indices of each finger: ``FINGER_CHANNELS[finger]`` = (distal, middle, root).
FINGER_CHANNELS = ((0, 1, 2), (3, 4, 5))
#: Position of a channel on its finger, the index inside a :data:`FINGER_CHANNELS` entry.
DISTAL, MIDDLE, ROOT = 0, 1, 2

#: Sampling rate of the sensor [Hz] and its period [s].
SAMPLE_RATE = 2000.0
SAMPLE_PERIOD = 1.0 / SAMPLE_RATE

#: Reading scale of the sensor board: 1024 counts = 1.0 normalised = +1 inH2O; readings are
#: clipped to +-1024 counts (docs/firmware.md).
COUNTS_PER_FULL_SCALE = 1024
#: Inclusive range of a normalised reading (the transducer's span, +-1 inH2O).
VALUE_RANGE = (-1.0, 1.0)
#: Quantisation step of the normalised 11-bit reading: 2048 levels over -1..1 [normalised].
QUANTUM = (VALUE_RANGE[1] - VALUE_RANGE[0]) / 2048.0

__all__ = ['CHANNEL_NAMES', 'COUNTS_PER_FULL_SCALE', 'DISTAL', 'FINGER_CHANNELS',
           'FINGER_NAMES', 'MIDDLE', 'N_CHANNELS', 'QUANTUM', 'ROOT', 'SAMPLE_PERIOD',
           'SAMPLE_RATE', 'VALUE_RANGE']
