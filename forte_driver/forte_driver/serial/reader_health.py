"""Health of the serial sensor node's reader thread and the level of its diagnostics.

Pure Python, no rclpy (used by :mod:`forte_driver.ros.serial_sensor_node`).

Rules (docs/serial_driver.md, "Reader errors"):

- Every unexpected exception in a step of the reader thread (read, decode/assemble/stamp,
  publish) is caught, counted in ``reader_errors`` and remembered (``last_reader_error``);
  the stream goes on with the next chunk. Port errors are not reader errors: they go
  through the reconnect path.
- Diagnostics are ERROR while the last reader error is younger than ``error_hold_s``;
  afterwards the level returns to what the stream deserves (OK, or WARN for a low rate)
  while the counter and the text stay in the values.
- If the thread ends anyway (a bug), the supervisor restarts it (``reader_restarts``); after
  ``max_restarts`` restarts within ``restart_window_s`` it gives up: the node deactivates and
  diagnostics stay ERROR until the next successful activation.
"""
from __future__ import annotations

from collections import deque

OK, WARN, ERROR = 'OK', 'WARN', 'ERROR'

#: Longest error text kept [characters].
MAX_ERROR_TEXT = 300


def describe_error(step: str, error: BaseException) -> str:
    """One-line text of an exception raised in reader step ``step``."""
    text = f'{step}: {type(error).__name__}: {error}'.replace('\n', ' ')
    return text if len(text) <= MAX_ERROR_TEXT else text[:MAX_ERROR_TEXT - 3] + '...'


class ReaderHealth:
    """Counts and remembers reader-thread failures; decides restarts.

    Parameters
    ----------
    error_hold_s : float
        How long a reader error keeps the diagnostics at ERROR [s].
    max_restarts : int
        Thread restarts allowed within ``restart_window_s`` before giving up [count].
    restart_window_s : float
        Window of the restart limit [s].

    Attributes
    ----------
    reader_errors : int
        Unexpected exceptions caught in reader steps [count].
    reader_restarts : int
        Times the reader thread was found dead and restarted [count].
    last_error : str
        Text of the last reader error or thread death ('' if none).
    failed : bool
        The supervisor gave up restarting the thread.
    """

    def __init__(self, error_hold_s: float = 5.0, max_restarts: int = 5,
                 restart_window_s: float = 60.0) -> None:
        self.error_hold_s = float(error_hold_s)
        self.max_restarts = int(max_restarts)
        self.restart_window_s = float(restart_window_s)
        self.reader_errors = 0
        self.reader_restarts = 0
        self.last_error = ''
        self.failed = False
        self._last_error_s: float | None = None
        self._restart_times: deque[float] = deque()

    def record_error(self, step: str, error: BaseException, now_s: float) -> str:
        """Count one exception of reader step ``step`` at monotonic time ``now_s`` [s];
        returns its text."""
        self.reader_errors += 1
        self.last_error = describe_error(step, error)
        self._last_error_s = now_s
        return self.last_error

    def record_thread_death(self, reason: str, now_s: float) -> None:
        """The reader thread ended while it should run (``reason``: what ended it)."""
        self.last_error = f'reader thread ended: {reason}'[:MAX_ERROR_TEXT]
        self._last_error_s = now_s

    def allow_restart(self, now_s: float) -> bool:
        """Whether the dead reader thread may be restarted now; counts the restart, or
        sets ``failed`` when the limit is reached."""
        while self._restart_times and now_s - self._restart_times[0] > self.restart_window_s:
            self._restart_times.popleft()
        if len(self._restart_times) >= self.max_restarts:
            self.failed = True
            return False
        self._restart_times.append(now_s)
        self.reader_restarts += 1
        return True

    def clear_failure(self) -> None:
        """A new activation starts with a fresh restart budget."""
        self.failed = False
        self._restart_times.clear()

    def error_active(self, now_s: float) -> bool:
        """True while the last error is younger than ``error_hold_s``."""
        return self._last_error_s is not None and now_s - self._last_error_s < self.error_hold_s


def diagnostics_level(state: str, connected: bool, rate_hz: float, nominal_rate_hz: float,
                      health: ReaderHealth, now_s: float) -> tuple[str, str]:
    """Level (``OK``, ``WARN``, ``ERROR``) and message of the sensor's diagnostics.

    Parameters
    ----------
    state : str
        Lifecycle state label.
    connected : bool
        The port is open.
    rate_hz : float
        Samples published per second over the last period [Hz].
    nominal_rate_hz : float
        Configured sample rate [Hz].
    health : ReaderHealth
        Reader-thread health.
    now_s : float
        Monotonic time [s].
    """
    if state == 'active' and not connected:
        return ERROR, 'device lost, reconnecting'
    if state == 'inactive' and not connected:
        return ERROR, 'device not connected'
    if health.failed:
        return ERROR, f'reader thread keeps failing, deactivated: {health.last_error}'
    if health.error_active(now_s):
        return ERROR, f'reader error: {health.last_error}'
    if state == 'active' and rate_hz < 0.9 * nominal_rate_hz:
        return WARN, f'rate {rate_hz:.0f} Hz below nominal {nominal_rate_hz:.0f} Hz'
    return OK, state
