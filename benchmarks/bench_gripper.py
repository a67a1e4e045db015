"""Benchmark of the Dynamixel gripper bus traffic against baselines measured in the same run.

The real dynamixel-sdk talks over a pty to the simulated XM430-W350 pair running in its
own process (Return Delay Time 500 us and 4 Mbaud transmission times modelled; the USB
latency of a real U2D2 is not). Three comparisons:

1. state sample of both fingers: ONE sync read of the 21-byte block (the driver) vs the
   baseline of individual reads (position, velocity, current, temperature per servo);
2. command of both fingers: ONE sync write (the driver) vs individual writes with status
   (goal current, profile velocity, goal position per servo);
3. host CPU share while sampling: blocking 1 ms serial reads (the driver's port setup) vs
   the SDK's default busy poll.

Run: ``python benchmarks/bench_gripper.py`` (about 16 s; ``--duration`` sets the seconds of
each of the five measurements, default 3).
"""
from __future__ import annotations

import argparse
import time

from dynamixel_sdk import COMM_SUCCESS

from forte_driver.dynamixel import control_table as ct
from forte_driver.dynamixel.gripper import Gripper, GripperConfig
from forte_driver.emulators.simulated_servo import SimulatedServoProcess

DURATION_S = 3.0


def rate(operation, duration: float = DURATION_S) -> tuple[float, float, int]:
    """Run ``operation`` repeatedly for ``duration`` s.

    Returns
    -------
    tuple
        (operations per second, host CPU seconds per wall second, failed operations).
    """
    count = failures = 0
    wall_start, cpu_start = time.perf_counter(), time.process_time()
    while time.perf_counter() - wall_start < duration:
        if not operation():
            failures += 1
        count += 1
    wall = time.perf_counter() - wall_start
    return count / wall, (time.process_time() - cpu_start) / wall, failures


def run(duration: float = DURATION_S) -> None:
    """Measure and print the three comparisons, each operation for ``duration`` s."""
    with SimulatedServoProcess(ids=(1, 2)) as bus:
        gripper = Gripper(GripperConfig(port=bus.device_path))
        gripper.open()
        gripper.configure()
        gripper.hold_present_position()
        gripper.set_torque(True)
        port, handler = gripper.port, gripper.packet_handler
        ids = (1, 2)

        def sync_read() -> bool:
            try:
                gripper.read_state()
                return True
            except Exception:
                return False

        def individual_reads() -> bool:
            ok = True
            for servo_id in ids:
                for register in (ct.PRESENT_POSITION, ct.PRESENT_VELOCITY,
                                 ct.PRESENT_CURRENT, ct.PRESENT_TEMPERATURE):
                    _, result, _ = handler.readTxRx(port, servo_id, register.address,
                                                    register.size)
                    ok = ok and result == COMM_SUCCESS
            return ok

        theta = [0.2]

        def sync_write() -> bool:
            theta[0] = 0.6 - theta[0]
            return gripper.command(theta[0], 0.3, 2.0).accepted

        def individual_writes() -> bool:
            theta[0] = 0.6 - theta[0]
            ok = True
            for finger in gripper.config.fingers:
                for register, value in ((ct.GOAL_CURRENT, 111), (ct.PROFILE_VELOCITY, 83),
                                        (ct.GOAL_POSITION, finger.theta_to_raw(theta[0]))):
                    result, error = handler.writeTxRx(port, finger.servo_id, register.address,
                                                      register.size,
                                                      list(ct.encode_value(register, value)))
                    ok = ok and result == COMM_SUCCESS and error == 0
            return ok

        print('gripper bus benchmark (dynamixel-sdk over a pty, simulated XM430-W350 pair '
              'in its own process, 4 Mbaud, return delay 500 us)')
        sync_rate, sync_cpu, sync_fail = rate(sync_read, duration)
        base_rate, base_cpu, base_fail = rate(individual_reads, duration)
        print(f'state of both fingers: sync read {sync_rate:8.1f} samples/s '
              f'(failed {sync_fail}) | baseline 8 individual reads {base_rate:8.1f} samples/s '
              f'(failed {base_fail}) | ratio {sync_rate / base_rate:5.2f}x')
        write_rate, _, write_fail = rate(sync_write, duration)
        base_write_rate, _, base_write_fail = rate(individual_writes, duration)
        print(f'command of both fingers: sync write {write_rate:8.1f} commands/s '
              f'(failed {write_fail}) | baseline 6 individual writes {base_write_rate:8.1f} '
              f'commands/s (failed {base_write_fail}) | ratio '
              f'{write_rate / base_write_rate:5.2f}x')
        port.ser.timeout = 0  # the SDK's own setting: busy poll
        spin_rate, spin_cpu, spin_fail = rate(sync_read, duration)
        blocking_ms = 1000.0 * sync_cpu / sync_rate
        spin_ms = 1000.0 * spin_cpu / spin_rate
        print(f'host CPU per state sample: blocking 1 ms reads {blocking_ms:6.3f} ms '
              f'({100 * sync_cpu:4.1f} % of a core at {sync_rate:.0f} samples/s) | baseline SDK '
              f'busy poll {spin_ms:6.3f} ms ({100 * spin_cpu:4.1f} % at {spin_rate:.0f} '
              f'samples/s, failed {spin_fail}) | ratio {spin_ms / blocking_ms:5.2f}x less CPU')
        print(f'100 Hz joint_states need {100 / sync_rate * 100:.0f} % of the bus time '
              f'with sync reads, {100 / base_rate * 100:.0f} % with individual reads')
        gripper.close()


def main(argv: list[str] | None = None) -> None:
    """Command line: ``[--duration SECONDS]``."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--duration', type=float, default=DURATION_S,
                        help=f'seconds of each measurement (default {DURATION_S})')
    run(parser.parse_args(argv).duration)


if __name__ == '__main__':
    main()
