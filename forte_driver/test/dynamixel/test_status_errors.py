"""The status packet error byte (protocol 2.0): bit 7 alert, bits 0..6 error number.

Specification (e-manual, issue "Never silently wrong at the edges"): a reply with an error
number (1 result fail, 2 instruction, 3 CRC, 4 data range, 5 data length, 6 data limit,
7 access) is not state and is never used; it is counted per servo and per kind. The alert
bit alone means a hardware error is latched: the reply's data are still readings, the
driver reads Hardware Error Status(70) and Torque Enable(64) once, and refuses commands
while the servo's shutdown keeps its torque off. Tests run the real dynamixel-sdk against
the simulated XM430-W350 pair, which injects each error kind on demand.
"""
import time

import pytest
from dynamixel_sdk import COMM_RX_TIMEOUT, COMM_SUCCESS, PacketHandler

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel import protocol as proto
from forte_driver.dynamixel.gripper import (
    DynamixelError,
    Gripper,
    GripperConfig,
    GripperLimits,
    StatusError,
)
from forte_driver.dynamixel.status_errors import (
    StatusErrorCounts,
    status_error_kinds,
    sync_read_with_status,
)
from forte_driver.emulators.servo_faults import StatusFaults
from forte_driver.emulators.simulated_servo import SimulatedServoProcess

ERROR_NUMBERS = {1: 'result fail', 2: 'instruction error', 3: 'CRC error',
                 4: 'data range error', 5: 'data length error', 6: 'data limit error',
                 7: 'access error'}
HARDWARE_ERRORS = {0x01: ('input voltage error', False), 0x04: ('overheating error', True),
                   0x08: ('motor encoder error', False),
                   0x10: ('electrical shock error', True), 0x20: ('overload error', True)}
"""bit -> (name, in the factory Shutdown(63) mask 0x34: torque switched off)."""
STATE_ADDRESS = 126


# -- pure parts ---------------------------------------------------------------------------


def test_error_byte_kinds_known_answers():
    assert status_error_kinds(0x00) == []
    for number, name in ERROR_NUMBERS.items():
        assert status_error_kinds(number) == [name]
    assert status_error_kinds(0x80) == ['alert']
    assert status_error_kinds(0x86) == ['data limit error', 'alert']
    assert status_error_kinds(0x0F) == ['unknown error 15']


def test_counts_per_servo_and_kind():
    counts = StatusErrorCounts()
    for error in (0x00, 0x04, 0x84, 0x80, 0x07):
        counts.record(2, error, 'sync read of state')
    counts.record(1, 0x80)
    assert counts.of(2) == {'data range error': 2, 'alert': 2, 'access error': 1}
    assert counts.of(1) == {'alert': 1} and counts.of(3) == {}
    assert counts.error_replies(2) == 3 and counts.error_replies(1) == 0
    assert counts.last_error[2] == 'sync read of state: access error'


def test_fault_injection_is_validated_and_consumed_in_order():
    faults = StatusFaults()
    for bad in ({'error_number': 0}, {'error_number': 128},
                {'error_number': 4, 'instruction': 'bulk read'},
                {'error_number': 4, 'count': 0}):
        with pytest.raises(ValueError):
            faults.inject(1, **bad)
    faults.inject(1, 4, 'sync read', count=2, address=126)
    faults.inject(1, 7, 'read', count=None)
    assert faults.spoil(1, proto.INSTRUCTION_SYNC_READ, 70, 0, b'x') == (0, b'x')
    assert faults.spoil(2, proto.INSTRUCTION_SYNC_READ, 126, 0, b'x') == (0, b'x')
    assert faults.spoil(1, proto.INSTRUCTION_SYNC_READ, 126, 0, b'x') == (4, b'x')
    assert faults.spoil(1, proto.INSTRUCTION_SYNC_READ, 126, 0, b'x') == (4, b'x')
    assert faults.spoil(1, proto.INSTRUCTION_SYNC_READ, 126, 0, b'x') == (0, b'x')
    for _ in range(5):
        assert faults.spoil(1, proto.INSTRUCTION_READ, 64, 0, b'') == (7, b'')
    assert faults.spoiled == 7
    assert faults.clear(2) == 0 and faults.clear() == 1 and faults.pending() == []


# -- the simulated servo over the pty, raw dynamixel-sdk ------------------------------------


@pytest.fixture
def bus():
    with SimulatedServoProcess(ids=(1, 2), positions=(2200, 1900)) as simulated:
        yield simulated


def test_simulated_servo_answers_injected_error_numbers_and_refuses_the_instruction(bus, port):
    handler = PacketHandler(2.0)
    bus.inject_status_error(1, 7, 'read', address=146)
    assert handler.read1ByteTxRx(port, 1, 146) == (30, COMM_SUCCESS, 7)  # data kept
    assert handler.read1ByteTxRx(port, 1, 146) == (30, COMM_SUCCESS, 0)  # one reply only
    bus.inject_status_error(2, 6, 'write')
    assert handler.write1ByteTxRx(port, 2, ct.LED.address, 1) == (COMM_SUCCESS, 6)
    assert bus.register_value(2, 'LED') == 0  # a refused write changes nothing
    bus.inject_status_error(2, 2, 'ping', keep_data=False)
    assert handler.ping(port, 2)[1:] == (COMM_SUCCESS, 2)
    bus.inject_hardware_error(2, ct.HW_ERROR_OVERLOAD)
    bus.inject_status_error(2, 1, 'reboot')
    assert handler.reboot(port, 2) == (COMM_SUCCESS, 0x81)  # alert + result fail
    assert bus.register_value(2, 'Hardware Error Status') == ct.HW_ERROR_OVERLOAD  # no reboot
    bus.inject_status_error(1, 4, 'sync read', count=None)
    assert bus.clear_status_errors() == 1
    with pytest.raises(RuntimeError, match='error number 0 outside'):
        bus.inject_status_error(1, 0)


# -- the gripper core: every error kind in every transaction --------------------------------


@pytest.fixture
def gripper(bus):
    device = Gripper(GripperConfig(port=bus.device_path, limits=GripperLimits()))
    device.open()
    device.configure()
    yield device
    device.close()


def _first_answer(operation, attempts=3):
    """Run ``operation``; retry only a lost/corrupt reply (the loaded test machine can miss
    the SDK's timeout), never a reply with an error number."""
    for attempt in range(attempts):
        try:
            return operation()
        except StatusError:
            raise
        except DynamixelError:
            if attempt == attempts - 1:
                raise


def _state_sync_reads(bus):
    return sum(1 for instruction, _, parameters in bus.packet_log()
               if instruction == proto.INSTRUCTION_SYNC_READ and parameters[0] == STATE_ADDRESS)


@pytest.mark.parametrize('keep_data', [True, False])
@pytest.mark.parametrize('number', [*ERROR_NUMBERS, 0x15])
def test_state_reply_with_an_error_number_is_not_state(bus, gripper, number, keep_data):
    _first_answer(gripper.read_state)
    bus.inject_status_error(2, number, 'sync read', count=3, address=STATE_ADDRESS,
                            keep_data=keep_data)
    with pytest.raises(StatusError) as raised:
        _first_answer(gripper.read_state)
    assert raised.value.errors == {2: number}
    name = ERROR_NUMBERS.get(number, f'unknown error {number}')
    assert name in str(raised.value) and 'servo 2: sync read of state' in str(raised.value)
    assert gripper.status_errors.of(2) == {name: 1}
    assert gripper.status_errors.of(1) == {}
    assert bus.clear_status_errors() == 1  # 2 of the 3 replies were not asked for yet
    state = _first_answer(gripper.read_state)
    assert state['left'].raw_position == 1900 and state['right'].raw_position == 2200
    assert gripper.status_errors.error_replies(2) == 1


@pytest.mark.parametrize('number', ERROR_NUMBERS)
def test_error_number_in_ping_read_write_and_hardware_error_sync_read(bus, gripper, number):
    name = ERROR_NUMBERS[number]
    calls = [
        ('ping', None, gripper.ping),
        ('read', ct.TORQUE_ENABLE.address, lambda: gripper.read_register(1, ct.TORQUE_ENABLE)),
        ('write', ct.LED.address, lambda: gripper.write_register(1, ct.LED, 1)),
        ('sync read', ct.HARDWARE_ERROR_STATUS.address, gripper.read_hardware_errors),
    ]
    for instruction, address, call in calls:
        bus.inject_status_error(1, number, instruction, address=address)
        with pytest.raises(StatusError, match=f'servo 1: .*{name}'):
            _first_answer(call)
    assert gripper.status_errors.of(1) == {name: 4}
    assert bus.register_value(1, 'LED') == 0  # the refused write changed nothing
    assert gripper.read_hardware_errors() == {1: 0, 2: 0}  # and the next ones work
    assert gripper.ping() == {1: 1020, 2: 1020}


@pytest.mark.parametrize('bit', HARDWARE_ERRORS)
def test_alert_bit_reads_the_hardware_error_once_and_keeps_the_readings(bus, gripper, bit):
    name, shutdown = HARDWARE_ERRORS[bit]
    gripper.hold_present_position()
    gripper.set_torque(True)
    bus.inject_hardware_error(2, bit)
    reads_of_70 = sum(1 for i, d, p in bus.packet_log()
                      if i == proto.INSTRUCTION_READ and p[0] == ct.HARDWARE_ERROR_STATUS.address)
    for _ in range(5):
        state = _first_answer(gripper.read_state)  # the alert bit alone: still readings
        assert state['left'].raw_position == 1900 and state['right'].raw_position == 2200
    alert = gripper.alerts[2]
    assert (alert.bits, alert.text, alert.torque_enabled) == (bit, name, not shutdown)
    assert 1 not in gripper.alerts
    assert gripper.status_errors.of(2)['alert'] >= 5 and gripper.status_errors.error_replies(2) == 0
    assert sum(1 for i, d, p in bus.packet_log()
               if i == proto.INSTRUCTION_READ
               and p[0] == ct.HARDWARE_ERROR_STATUS.address) == reads_of_70 + 1  # once
    writes = bus.count(proto.INSTRUCTION_SYNC_WRITE)
    check = gripper.command(0.5)
    # A read after the command: the servo handles packets in order, so any sync write
    # the command sent has been received when its answer comes.
    assert gripper.read_hardware_errors() == {1: 0, 2: bit}
    if shutdown:  # torque off inside the servo: a command would not move it
        assert not check.accepted and check.hardware_error
        assert f'servo 2: hardware error latched ({name}), torque off' in check.reasons[0]
        assert bus.count(proto.INSTRUCTION_SYNC_WRITE) == writes
    else:  # not in the Shutdown mask: the servo still obeys
        assert check.accepted and not check.hardware_error
        assert bus.count(proto.INSTRUCTION_SYNC_WRITE) == writes + 1
    handler = PacketHandler(2.0)
    assert handler.reboot(gripper.port, 2)[0] == COMM_SUCCESS
    _first_answer(gripper.read_state)  # no alert bit any more: forgotten
    assert gripper.alerts == {}
    assert gripper.command(0.5).accepted


def test_error_number_and_alert_bit_together(bus, gripper):
    bus.inject_hardware_error(1, ct.HW_ERROR_OVERHEATING)
    bus.inject_status_error(1, 5, 'sync read', address=STATE_ADDRESS)
    with pytest.raises(StatusError) as raised:
        _first_answer(gripper.read_state)
    assert raised.value.errors == {1: 0x85}
    assert 'data length error, alert (hardware error latched)' in str(raised.value)
    # Every status packet counts: the state reply, then the reads of 70 and 64 it caused.
    assert gripper.status_errors.of(1) == {'data length error': 1, 'alert': 3}
    assert gripper.alerts[1].bits == ct.HW_ERROR_OVERHEATING  # read although no state used


def test_healthy_state_read_adds_no_transaction(bus, gripper):
    """The check costs no bus time: one sync read per sample, nothing else."""
    before = len(bus.packet_log())
    for _ in range(20):
        _first_answer(gripper.read_state)
    log = bus.packet_log()[before:]
    assert len(log) >= 20
    assert {(i, p[0]) for i, _, p in log} == {(proto.INSTRUCTION_SYNC_READ, STATE_ADDRESS)}
    assert gripper.status_errors.of(1) == {} == gripper.status_errors.of(2)


def test_a_silent_servo_is_still_a_communication_failure_not_a_status_error(bus, gripper):
    bus.set_servo(2, responding=False)
    with pytest.raises(DynamixelError, match='servo 2: .*no status packet') as raised:
        gripper.read_state()
    assert not isinstance(raised.value, StatusError)
    handler = PacketHandler(2.0)
    assert handler.ping(gripper.port, 2)[1] == COMM_RX_TIMEOUT


# -- a reply that came after its timeout -----------------------------------------------------


class _AlreadySent:
    """The state sync read as it stands once its instruction went out: the ids, the block
    length, and a send that already happened (the late reply then lands on the port)."""

    def __init__(self, reader):
        self.data_dict, self.data_length = reader.data_dict, reader.data_length

    def txPacket(self) -> int:
        return COMM_SUCCESS


def _leave_a_late_reply(port, servo_id: int) -> int:
    """Send READ Hardware Error Status(70) to ``servo_id`` and do not receive its reply, as
    when the driver's timeout expired before the servo answered; returns the reply's size
    in bytes once it is waiting on the port (header 3, reserved, id, length 2, instruction,
    error, 1 data byte, CRC 2)."""
    handler = PacketHandler(2.0)
    packet = [0] * 14
    packet[4], packet[7] = servo_id, proto.INSTRUCTION_READ
    packet[8:12] = [ct.HARDWARE_ERROR_STATUS.address, 0, 1, 0]
    packet[5], packet[6] = 7, 0
    assert handler.txPacket(port, packet) == COMM_SUCCESS
    port.is_using = False  # what the SDK's receive does when it gives up
    expected = 12
    for _ in range(200):
        if port.ser.in_waiting >= expected:
            break
        time.sleep(0.005)
    assert port.ser.in_waiting == expected
    return expected


def test_a_late_reply_waiting_on_the_port_is_not_taken_for_the_next_answer(bus, gripper):
    """Bytes left on the half-duplex bus before an instruction (a reply that came after
    its timeout) are dropped when the next instruction is sent (dynamixel-sdk clears the
    input): the sync read decodes the present positions, not the late 1-byte reply."""
    truth = {finger.name: bus.register_value(finger.servo_id, 'Present Position')
             for finger in gripper.config.fingers}
    _leave_a_late_reply(gripper.port, 2)
    state = gripper.read_state()
    for name, raw in truth.items():
        assert state[name].raw_position == raw
    _leave_a_late_reply(gripper.port, 1)
    mode = bus.register_value(1, 'Operating Mode')
    assert mode != 0 and gripper.read_register(1, ct.OPERATING_MODE) == mode  # single reads


def test_a_status_packet_of_another_length_is_not_data(bus, gripper):
    """A late reply that lands after the next instruction was sent (a slow servo, a busy
    host): the receive loop sees the first servo's 1-byte reply where a state block was
    asked for; the driver raises (as for a lost reply) instead of slicing it into a state."""
    first = next(iter(gripper._state_read.data_dict))
    _leave_a_late_reply(gripper.port, first)
    expected = (f'servo {first}: a status packet of 1 data bytes, '
                f'expected {ct.STATE_BLOCK_LENGTH} ')
    with pytest.raises(DynamixelError, match=expected + '.*late reply'):
        sync_read_with_status(_AlreadySent(gripper._state_read), gripper.packet_handler,
                              gripper.port, 'sync read of state')
