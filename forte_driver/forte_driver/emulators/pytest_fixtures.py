"""pytest fixtures of the tests that talk to the simulated servos (test support, no rclpy).

Imported by the ``conftest.py`` of forte_driver's and forte_sim's tests (the driver against
its fake hardware, the bench twin). The simulated servo answers from a Python process on a
shared 2-core machine, so its status packets can take longer than a servo's silicon.
dynamixel-sdk derives every packet timeout from its ``LATENCY_TIMER`` setting (16 ms, the
U2D2's USB latency timer); raising it for these tests gives the peer the slack a slow USB
adapter would need, without changing any protocol behaviour: a servo that does not answer at
all still times out.
"""
from __future__ import annotations

import dynamixel_sdk.port_handler
import pytest
from dynamixel_sdk import PortHandler

__all__ = ['SIMULATED_SERVO_LATENCY_MS', 'port', 'slow_peer_latency']

#: Latency allowance for the simulated servo [ms] (packet timeout = 2 x this + 2 ms + bytes).
SIMULATED_SERVO_LATENCY_MS = 64


@pytest.fixture(autouse=True)
def slow_peer_latency(monkeypatch):
    monkeypatch.setattr(dynamixel_sdk.port_handler, 'LATENCY_TIMER', SIMULATED_SERVO_LATENCY_MS)


@pytest.fixture
def port(bus):
    """The simulated servo pair's pty opened at 4 Mbaud with the real dynamixel-sdk
    (``bus``: a ``SimulatedServoProcess`` fixture of the test module)."""
    handler = PortHandler(bus.device_path)
    assert handler.openPort() and handler.setBaudRate(4_000_000)
    yield handler
    handler.closePort()
