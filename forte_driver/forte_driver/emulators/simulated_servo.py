"""Simulated pair of XM430-W350 servos speaking DYNAMIXEL protocol 2.0 on a pseudo-terminal.

The real dynamixel-sdk (``PortHandler`` on :attr:`SimulatedServoBus.device_path`) talks
to it exactly as to a U2D2 with two servos on the bus: instruction packets in, status
packets out, with CRC-16, byte stuffing, the status error byte, the return delay time and
the transmission time of the configured baud rate. Modelled: PING, READ, WRITE, SYNC READ,
SYNC WRITE, REBOOT; the XM430-W350 control table rules (EEPROM, access, length, range and
limit errors; a refused write changes nothing); Status Return Level, Return Delay Time,
Baud Rate; motion, current, temperature; hardware errors (overheating, input voltage,
overload, injected ones) with the alert bit in every status and, for bits in Shutdown(63),
torque off until REBOOT; error numbers injected in the status of a given instruction
(:mod:`forte_driver.emulators.servo_faults`). The full list, and what is not modelled, is
in docs/gripper_driver.md.

Three modules, one concern each: :mod:`.simulated_xm430` (one servo's control table and
physics, no I/O), :mod:`.simulated_servo_bus` (the servos on a pty, served by a thread) and
this one (:class:`SimulatedServoProcess`, the bus in its own process, and the command
line). :class:`SimulatedXM430` and :class:`SimulatedServoBus` are re-exported here.

Run ``forte_simulated_servo`` to get a bus on a pty from the command line; it prints the
device path (and can symlink it to a stable name with ``--link``).
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import threading

from forte_driver.dynamixel import control_table as ct
from forte_driver.emulators.simulated_servo_bus import ReceivedPacket, SimulatedServoBus
from forte_driver.emulators.simulated_xm430 import SimulatedXM430

__all__ = ['ReceivedPacket', 'SimulatedServoBus', 'SimulatedServoProcess', 'SimulatedXM430',
           'main']


def _serve_control(bus: SimulatedServoBus, stop: threading.Event) -> None:
    """Answer JSON-line calls on stdin (``{"call": name, "args": [...], "kwargs": {...}}``)
    with one JSON line each on stdout (``{"ok": true, "value": ...}``)."""
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            name = request['call']
            if name not in SimulatedServoProcess.FORWARDED:
                raise AttributeError(f'{name} is not a control call')
            value = getattr(bus, name)(*request.get('args', []), **request.get('kwargs', {}))
            if name == 'packet_log':
                value = [(i, d, p.hex()) for i, d, p in value]
            reply = {'ok': True, 'value': value}
        except Exception as error:  # report to the caller, keep serving
            reply = {'ok': False, 'value': f'{type(error).__name__}: {error}'}
        print(json.dumps(reply), flush=True)
    stop.set()


class SimulatedServoProcess:
    """A :class:`SimulatedServoBus` in its own process (``forte_simulated_servo
    --control``), so that its answer times do not depend on the host process's threads
    and interpreter lock, like a real device.

    The inspection and fault-injection methods of the bus (:attr:`FORWARDED`) are
    forwarded as JSON lines over the child's stdin/stdout.
    """

    FORWARDED = ('count', 'packet_log', 'register_value', 'inject_hardware_error',
                 'inject_status_error', 'clear_status_errors', 'set_servo', 'exchange')

    def __init__(self, ids=(1, 2), baud_rate: int = 4_000_000, positions=None):
        self._arguments = ['--ids', *map(str, ids), '--baud', str(baud_rate)]
        if positions is not None:
            self._arguments += ['--positions', *map(str, positions)]
        self._process: subprocess.Popen | None = None
        self._call_lock = threading.Lock()
        self.device_path = ''

    def start(self) -> SimulatedServoProcess:
        """Start the process and wait for its pty path."""
        self._process = subprocess.Popen(
            [sys.executable, '-m', 'forte_driver.emulators.simulated_servo', '--control',
             *self._arguments],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1)
        self.device_path = self._process.stdout.readline().strip()
        if not self.device_path:
            self.stop()
            raise RuntimeError('simulated servo process did not start')
        return self

    def stop(self) -> None:
        """Stop the process (closes the pty)."""
        if self._process is None:
            return
        try:
            self._process.stdin.close()
            self._process.wait(timeout=5.0)
        except (OSError, subprocess.TimeoutExpired):
            self._process.kill()
            self._process.wait()
        self._process.stdout.close()
        self._process = None

    def __enter__(self) -> SimulatedServoProcess:
        return self.start()

    def __exit__(self, *exc_info) -> None:
        self.stop()

    def call(self, name: str, *args, **kwargs):
        """Call method ``name`` of the bus in the child process and return its result."""
        if name not in self.FORWARDED:
            raise AttributeError(name)
        with self._call_lock:
            self._process.stdin.write(json.dumps(
                {'call': name, 'args': list(args), 'kwargs': kwargs}) + '\n')
            self._process.stdin.flush()
            reply = json.loads(self._process.stdout.readline())
        if not reply['ok']:
            raise RuntimeError(reply['value'])
        if name == 'packet_log':
            return [(i, d, bytes.fromhex(p)) for i, d, p in reply['value']]
        return reply['value']

    def __getattr__(self, name: str):
        if name in SimulatedServoProcess.FORWARDED:
            return lambda *args, **kwargs: self.call(name, *args, **kwargs)
        raise AttributeError(name)


def main(argv: list[str] | None = None) -> int:
    """Command line: serve simulated XM430-W350 servos on a pty until interrupted."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--ids', type=int, nargs='+', default=[1, 2],
                        help='servo ids on the bus (default: 1 2)')
    parser.add_argument('--baud', type=int, default=4_000_000,
                        choices=sorted(ct.REGISTER_BY_BAUD_RATE),
                        help='Baud Rate register of the servos [bit/s] (default 4000000)')
    parser.add_argument('--positions', type=int, nargs='+', default=None,
                        help='initial present positions [pulse], one per id (default 2048)')
    parser.add_argument('--link', default='',
                        help='also create a symlink with this path to the pty device')
    parser.add_argument('--duration', type=float, default=0.0,
                        help='stop after this many seconds (default: run until SIGINT)')
    parser.add_argument('--control', action='store_true',
                        help='answer JSON-line inspection/fault-injection calls on stdin '
                             '(used by SimulatedServoProcess); stops when stdin closes')
    args = parser.parse_args(argv)
    bus = SimulatedServoBus(args.ids, args.baud, args.positions)
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):  # a clean stop, also during start-up
        signal.signal(signum, lambda *_: stop.set())
    bus.start()
    if args.link:
        if os.path.islink(args.link):
            os.unlink(args.link)
        os.symlink(bus.device_path, args.link)
    print(bus.device_path, flush=True)
    if args.control:
        threading.Thread(target=_serve_control, args=(bus, stop), daemon=True).start()
    try:
        stop.wait(args.duration if args.duration > 0 else None)
    except KeyboardInterrupt:
        pass
    finally:
        bus.stop()
        if args.link and os.path.islink(args.link):
            os.unlink(args.link)
        if not args.control:
            print(f'packets: {sum(bus.instruction_counts.values())}, '
                  f'crc errors: {bus.crc_errors}', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
