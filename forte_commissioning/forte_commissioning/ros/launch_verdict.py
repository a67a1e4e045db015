"""A procedure's verdict as its launch's exit status: 0 PASS, 1 FAIL, 2 no data.

A procedure's command (``forte_commission``, ``forte_calibrate_force``) exits 0 when it
passed, 1 when it failed and 2 when it got no data to judge (a dead device, a link that
never came). Its launch file must end when the procedure ends and exit the same way, so that
a lab can script ``ros2 launch forte_commissioning commission.launch.py ...`` like the
command. ``ros2 launch`` cannot say so by itself: it exits with ``LaunchService.run()``'s
code, 0, or 1 after an exception in the launch. :class:`ProcedureVerdict` therefore

- ends the launch when the procedure exits, keeping its code (:meth:`procedure_ended`);
- ends it with code 2 when a device the procedure needs (the bench twin, a driver) exits
  before the procedure has ended (:meth:`device_ended`): a misspelt ``sensor_fault`` makes
  the bench twin exit at once, and the launch then ends within seconds instead of waiting
  for links that will never appear;
- at the exit of the ``ros2 launch`` process, after the launch has shut every process down
  and ``ros2`` has returned, sets the process's exit status to the verdict (an ``atexit``
  handler: flush the output and the logs, then ``os._exit(code)``). Only in the ``ros2``
  command: a launch run in another process (a test's ``LaunchService``) keeps its own exit
  status and reads :attr:`ProcedureVerdict.code`.

A launch interrupted before the procedure ended (Ctrl-C) keeps ``ros2 launch``'s status.
"""
from __future__ import annotations

import atexit
import logging
import os
import sys

from launch import LaunchContext
from launch.actions import EmitEvent, LogInfo, RegisterEventHandler
from launch.event_handlers import OnProcessExit
from launch.events import Shutdown
from launch.events.process import ProcessExited

__all__ = ['EXIT_FAIL', 'EXIT_NO_DATA', 'EXIT_PASS', 'ProcedureVerdict']

EXIT_PASS, EXIT_FAIL, EXIT_NO_DATA = 0, 1, 2
VERDICTS = {EXIT_PASS: 'PASS', EXIT_FAIL: 'FAIL', EXIT_NO_DATA: 'no data'}


class ProcedureVerdict:
    """The exit status of one procedure's launch.

    Parameters
    ----------
    procedure : str
        Its name in the log lines, e.g. ``'commissioning'``.
    """

    def __init__(self, procedure: str) -> None:
        self.procedure = procedure
        self.code: int | None = None  # None: the procedure has not ended
        if os.path.basename(sys.argv[0]) == 'ros2':
            atexit.register(self._exit_with_verdict)

    def procedure_ended(self, action) -> RegisterEventHandler:
        """End the launch when ``action`` (the procedure's process) exits, with its code
        (any code but 0 and 1 is 2: the procedure could not judge)."""
        def ended(event: ProcessExited, context: LaunchContext) -> list:
            code = event.returncode if event.returncode in VERDICTS else EXIT_NO_DATA
            if self.code is None:
                self.code = code
            return self._end(context, f'{self.procedure} ended: {VERDICTS[self.code]} '
                                      f'(exit {self.code})')

        return RegisterEventHandler(OnProcessExit(target_action=action, on_exit=ended))

    def device_ended(self, action, device: str) -> RegisterEventHandler:
        """End the launch with code 2 when ``action`` (a device ``device`` the procedure
        needs) exits before the procedure has ended."""
        def ended(event: ProcessExited, context: LaunchContext) -> list:
            if context.is_shutdown:
                return []
            return self.no_data(context, f'{device} exited (code {event.returncode}) before '
                                         f'the {self.procedure} ended')

        return RegisterEventHandler(OnProcessExit(target_action=action, on_exit=ended))

    def no_data(self, context: LaunchContext, message: str) -> list:
        """End the launch with code 2 (unless the procedure has ended): ``message`` says
        what is missing."""
        if self.code is not None:
            return []
        self.code = EXIT_NO_DATA
        return self._end(context, f'{message}: no data (exit {self.code})')

    def _end(self, context: LaunchContext, message: str) -> list:
        if context.is_shutdown:
            return [LogInfo(msg=message)]
        return [LogInfo(msg=message), EmitEvent(event=Shutdown(reason=message))]

    def _exit_with_verdict(self) -> None:
        if self.code in (None, EXIT_PASS):
            return
        for stream in (sys.stdout, sys.stderr):
            stream.flush()
        logging.shutdown()
        os._exit(self.code)
