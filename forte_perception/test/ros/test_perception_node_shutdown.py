"""perception_node, as its real executable, stops cleanly on SIGINT and SIGTERM while frames
stream in: exit code 0 within a few seconds, no traceback."""
from __future__ import annotations

import signal

import numpy as np
import pytest
from rclpy.qos import qos_profile_sensor_data

from forte_msgs.msg import TactileFrames, TactileState
from forte_ros.qos import TACTILE_STATE
from forte_ros.testing import NodeProcess, Probe, wait_until

CHANNELS = ['left_distal', 'left_middle', 'left_root', 'right_distal', 'right_middle',
            'right_root']
BATCH = 20


def stream_frames(probe: Probe) -> None:
    """Publish 2 kHz noise in batches of 20 (100 messages/s) from the probe's executor."""
    publisher = probe.node.create_publisher(TactileFrames, 'tactile/frames',
                                            qos_profile_sensor_data)
    random = np.random.default_rng(3)
    sequence = [0]

    def publish() -> None:
        message = TactileFrames()
        message.header.stamp = probe.node.get_clock().now().to_msg()
        message.header.frame_id = 'forte_base_link'
        message.first_sequence = sequence[0]
        message.device_time_us = sequence[0] * 500
        message.sample_period = 0.0005
        message.channel_names = CHANNELS
        message.sample_count = BATCH
        message.data = (0.01 * random.standard_normal(BATCH * 6)).tolist()
        publisher.publish(message)
        sequence[0] += BATCH

    probe.node.create_timer(0.01, publish)


@pytest.mark.parametrize('signum', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_perception_node_stops_cleanly_while_processing(signum):
    with Probe('perception_shutdown_probe') as probe:
        probe.count(TactileState, 'tactile/state', TACTILE_STATE)
        stream_frames(probe)
        with NodeProcess(['perception_node']) as process:
            assert wait_until(lambda: probe.counts['tactile/state'] >= 50, 40.0), \
                process.output
            process.stop_cleanly(signum)
