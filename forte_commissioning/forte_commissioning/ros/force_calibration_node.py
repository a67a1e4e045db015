"""``forte_calibrate_force``: the paper's force calibration on the gripper, through ROS.

A node that runs :class:`forte_commissioning.force_calibration.ForceCalibration` over
:class:`forte_commissioning.ros.calibration_rig.RosCalibrationRig`: per indentor an operator prompt,
theta_zeroF by the contact rule, N trials closing to random angles against the load cell;
each trial aligned to the load cell by sample time and kept on disk as soon as it is
complete; the contract's calibration ``.npz`` and an MCAP bag of each run in the session
folder. ``forte_train_force <session>/calibration.npz`` then trains and cross-validates.

    ros2 launch forte_commissioning calibrate_force.launch.py mode:=sim quick:=true
    ros2 launch forte_commissioning calibrate_force.launch.py mode:=hardware \\
        load_cell_topic:=/ati/wrench load_cell_axis:=z load_cell_sign:=-1
    ros2 service call /force_calibration/continue std_srvs/srv/Trigger   # after a prompt

Interrupted (Ctrl-C, a stale sensor, a crash), it keeps every finished trial; started again
with the same ``session_dir`` it resumes with the next trial. It refuses to start (exit code
2, one line saying why) on a stale sensor, without load-cell data, on a load-cell topic of
another type, or on a session folder made with other settings. Exit code 1 when trials were
lost (every attempt dropped), 0 otherwise.

The gripper is commanded by this node alone (``gripper/command``): the launch file starts
no grasp controller (an idle one would publish nothing). Load cell: any driver publishing
geometry_msgs/WrenchStamped with the *sample* time in the header (``load_cell_axis`` and
``load_cell_sign`` select the component that reads the squeeze as positive); the simulated
rig publishes +z at 100 Hz. In simulation the procedure must keep up with the simulator
(dropped trials with load-cell gaps in the log are the sign it does not): 4x real time (the
launch default) is safe on a free 2-core machine.

Measured (2-core machine shared with other jobs, docs of the commands in the launch file):

- quick (6 x 8 trials, 6 s holds), ``quick:=true``: 97 s of session at 8x real time
  (106 s with start-up), 96 s at 6x; 10-fold CV RMSE 0.130 / 0.134 N (two runs) against
  0.134 N of ``forte_sim_dataset --quick`` + ``forte_train_force`` (same draws); the model
  lifts the raspberry in the sim graph (LIFTED, ground truth HELD);
  ``forte_commissioning/test/test_calibrate_force_graph.py`` checks all of it (~130 s);
- full (6 x 40 trials, 12 s holds), the default, at the launch default of 4x real time:
  18 min (1058 s of session), 240/240 trials, 3 attempts dropped and repeated (a load-cell
  gap, twice a 0.5 s stale sensor while other jobs loaded the machine); its CV RMSE 0.1255 N
  against 0.126 N offline; ``forte_train_force`` on either file: about 15 min for the CV
  (history features; the same again for the latest-frame baseline).
"""
from __future__ import annotations

from dataclasses import replace

import rclpy
from rclpy.node import Node

from forte_commissioning.force_calibration import ForceCalibration, RigError
from forte_commissioning.force_plan import ForceCalibrationConfig
from forte_commissioning.load_cell import AXES
from forte_commissioning.ros.calibration_rig import RosCalibrationRig
from forte_commissioning.session_store import SessionError, SessionStore
from forte_ros import NodeRunner
from forte_ros.parameter_table import ParameterSpec, parameter_table, replace_fields
from forte_ros.parameters import declare_table, read_table
from forte_sim.dataset import QUICK_PROTOCOL

__all__ = ['PARAMETERS', 'ForceCalibrationNode', 'main']

#: Parameters of the node. Entries with ``field`` set :class:`ForceCalibrationConfig`.
PARAMETERS: dict[str, ParameterSpec] = parameter_table([
    ParameterSpec('session_dir', str, 'session folder: trials, session.json, bags, dataset; an '
                  'existing session there is resumed', default='force_calibration_session',
                  read_only=True),
    ParameterSpec('output', str, 'calibration dataset .npz (empty: calibration.npz in '
                  'session_dir)', default='', read_only=True),
    ParameterSpec('quick', bool, 'the quick protocol (forte_sim.dataset.QUICK_PROTOCOL: 8 '
                  'trials per indentor, 6 s holds, 1.5 s release); overrides the protocol '
                  'parameters', default=False, read_only=True),
    ParameterSpec('trials_per_indentor', int, 'trials per indentor (paper: 40)', low=1,
                  high=1000, field='protocol.trials_per_indentor', read_only=True),
    ParameterSpec('quiet_seconds', float, 'open and still at the start of a trial (its tare '
                  'baseline)', 's', 0.1, 60.0, field='protocol.quiet_seconds', read_only=True),
    ParameterSpec('hold_seconds', float, 'hold at the drawn angle', 's', 0.1, 600.0,
                  field='protocol.hold_seconds', read_only=True),
    ParameterSpec('release_seconds', float, 'open and rest at the end of a trial', 's', 0.1,
                  60.0, field='protocol.release_seconds', read_only=True),
    ParameterSpec('seed', int, 'seed of the closure draws (and of the simulated scenes)',
                  low=0, high=2 ** 31 - 1, field='protocol.seed', read_only=True),
    ParameterSpec('indentors', list, 'indentor names in the order they are mounted',
                  field='indentors', read_only=True),
    ParameterSpec('mount_angle', float, 'the gripper opens to this angle for mounting an '
                  'indentor; the theta_zeroF search starts there', 'rad', 0.05, 1.0,
                  field='mount_angle', read_only=True),
    ParameterSpec('open_margin', float, 'open pose beyond theta_zeroF', 'rad', 0.01, 1.0,
                  field='open_margin', read_only=True),
    ParameterSpec('search_velocity', float, 'servo speed of the theta_zeroF search', 'rad/s',
                  0.005, 0.5, field='search_velocity', read_only=True),
    ParameterSpec('search_floor', float, 'the theta_zeroF search stops (fails) at this angle',
                  'rad', 0.0, 1.0, field='search_floor', read_only=True),
    ParameterSpec('contact_threshold', float, 'tau of the sensor contact rule (0.5 % of full '
                  'scale)', low=0.001, high=0.5, field='contact_threshold', read_only=True),
    ParameterSpec('contact_window', int, 'w of the sensor contact rule', 'samples', 2, 4000,
                  field='contact_window', read_only=True),
    ParameterSpec('contact_force', float, 'load-cell contact level above its quiet mean', 'N',
                  0.001, 5.0, field='contact_force', read_only=True),
    ParameterSpec('load_cell_max_gap', float, 'longest load-cell interval a frame is '
                  'interpolated across (a wider one drops the trial)', 's', 0.0005, 1.0,
                  field='load_cell_max_gap', read_only=True),
    ParameterSpec('tare_load_cell', bool, "subtract each trial's quiet load-cell mean",
                  field='tare_load_cell', read_only=True),
    ParameterSpec('max_attempts', int, 'attempts per trial (a dropped trial is repeated)',
                  low=1, high=10, field='max_attempts', read_only=True),
    ParameterSpec('load_cell_topic', str, 'the load cell (geometry_msgs/WrenchStamped, header '
                  'stamp = sample time)', default='load_cell/wrench', read_only=True),
    ParameterSpec('load_cell_axis', str, 'wrench.force component that reads the squeeze',
                  choices=AXES, default='z', read_only=True),
    ParameterSpec('load_cell_sign', int, 'sign that makes a squeeze positive (+1 or -1)',
                  low=-1, high=1, integer_step=2, default=1, read_only=True),
    ParameterSpec('frames_reliable', bool, 'reliable subscription to tactile/frames (the '
                  'driver must publish reliable: reliable:=true); false: best effort',
                  default=False, read_only=True),
    ParameterSpec('stale_timeout', float, 'no frame for this long is a stale sensor (wall '
                  'time)', 's', 0.05, 10.0, default=0.5, read_only=True),
    ParameterSpec('ready_timeout', float, 'longest wait for frames and load cell at start',
                  's', 0.1, 60.0, default=3.0, read_only=True),
    ParameterSpec('simulation', bool, 'drive the sim node: a fresh calibration scene per '
                  'trial through its lifecycle, no operator prompts', default=False,
                  read_only=True),
    ParameterSpec('sim_node', str, 'the sim node (simulation mode)', default='sim',
                  read_only=True),
    ParameterSpec('auto_continue', bool, 'headless: go on after each operator prompt by '
                  'itself after auto_continue_delay', default=False, read_only=True),
    ParameterSpec('auto_continue_delay', float, 'wait after a prompt with auto_continue', 's',
                  0.0, 600.0, default=10.0, read_only=True),
    ParameterSpec('record_bag', bool, 'write an MCAP bag of each run in session_dir/bags',
                  default=True, read_only=True),
])


def config_from(values: dict) -> ForceCalibrationConfig:
    """The procedure's settings from the parameter values."""
    config = replace_fields(ForceCalibrationConfig(), PARAMETERS, values)
    if values.get('quick'):
        # the quick protocol's values replace those left at the full protocol's defaults
        full = ForceCalibrationConfig().protocol
        quick = {name: getattr(QUICK_PROTOCOL, name) for name in vars(full)
                 if getattr(config.protocol, name) == getattr(full, name)}
        config = replace(config, protocol=replace(config.protocol, **quick))
    return replace(config, indentors=tuple(config.indentors))


class ForceCalibrationNode(Node):
    """The procedure as a node; the session runs as a task of the node's executor.

    Raises
    ------
    SessionError
        The session folder holds another session.
    ValueError
        Unusable settings.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__('force_calibration', **kwargs)
        declare_table(self, PARAMETERS, ForceCalibrationConfig())
        self.settings = read_table(self, PARAMETERS)
        config = config_from(self.settings)
        problems = config.problems()
        if problems:
            raise ValueError('; '.join(problems))
        self.store = SessionStore(self.settings['session_dir'], config)
        self.rig = RosCalibrationRig(
            self, self.settings, self.store.bag_path() if self.settings['record_bag'] else None)
        self.procedure = ForceCalibration(self.rig, self.store, self._log,
                                          self.settings['output'] or None)
        self.exit_code: int | None = None
        self.report = None
        self._task = None
        self._start_timer = self.create_timer(0.2, self._start)

    def _log(self, text: str) -> None:
        self.get_logger().info(text)

    def _start(self) -> None:
        """One-shot: start the session task once the executor spins."""
        self.destroy_timer(self._start_timer)
        self._task = self.executor.create_task(self._run)

    async def _run(self) -> None:
        try:
            self.report = await self.procedure.run()
        except RigError as error:
            done = self.store.done_count()
            self.get_logger().error(
                f'{error}. {done}/{len(self.store.plan)} trials are kept in '
                f'{self.store.folder}; start again with the same session_dir to resume')
            self.exit_code = 2
            return
        except Exception as error:  # noqa: BLE001 - report, keep the recorded trials
            self.get_logger().error(f'force calibration failed: {error!r}; finished trials '
                                    f'are kept in {self.store.folder}')
            self.exit_code = 3
            return
        self.exit_code = 1 if self.report.lost else 0

    @property
    def finished(self) -> bool:
        """The session task ended (successfully or not)."""
        return self.exit_code is not None

    def prepare_shutdown(self) -> None:
        """Stop the task, open the gripper to ``mount_angle`` (off the load cell), finish
        the bag."""
        if self._task is not None and not self._task.done():
            self._task.cancel()
            self.rig.command(self.procedure.config.mount_angle)
            self.get_logger().warning(
                f'interrupted: {self.store.done_count()}/{len(self.store.plan)} trials kept in '
                f'{self.store.folder}; start again with the same session_dir to resume')
        self.rig.stop_recording()
        self.rig.close()


def main(args: list[str] | None = None) -> int:
    """Run the calibration session; exit codes in the module docstring."""
    with NodeRunner(args) as runner:
        try:
            node = ForceCalibrationNode()
        except (SessionError, ValueError, OSError) as error:
            rclpy.logging.get_logger('force_calibration').fatal(str(error))
            return 2
        runner.add_node(node)
        runner.spin(until=lambda: node.finished)
        code = node.exit_code
    if code is None:
        return 0  # stopped by a signal: the session is resumable
    if node.report is not None and node.report.dataset is not None:
        print(f'force calibration: {node.report.dataset} '
              f'({node.report.done}/{node.report.total} trials)', flush=True)
    return code


if __name__ == '__main__':
    raise SystemExit(main())
