#!/usr/bin/env bash
# One-command setup of the FORTE workspace (called by `make setup`).
#
#   tools/setup.sh [--launch-kit DIR]        (or FORTE_LAUNCH_KIT=DIR tools/setup.sh)
#
# Two kinds of machine, one build path (colcon), decided before anything else:
# - ROS 2 Jazzy sourced (ROS_DISTRO=jazzy and its Python imports rclpy): the venv is made
#   with that Python (3.12 on Ubuntu 24.04) and the system site-packages; only what ROS does
#   not provide is pip-installed (requirements/python.txt, and colcon if it is missing).
# - Bare machine: the venv gets the pinned ROS 2 Jazzy wheels (rclpy, Fast DDS, the rosidl
#   generators; requirements/ros.txt) and becomes the "ROS underlay": .venv/local_setup.bash
#   sets what /opt/ros/jazzy/setup.bash would. With --launch-kit DIR (a copy of
#   shared/ros2-launch-kit) it also gets launch, launch_ros, launch_pytest, the ros2 command
#   line, and the composition_interfaces and control_msgs interfaces, built into
#   .venv/opt/ros2_launch_kit; the kit is remembered, later runs need not name it again.
# Then `colcon build --symlink-install` builds the ten FORTE packages into install/ (the
# same command a ROS user types); `source install/setup.bash` gives the whole environment.
#
# Idempotent: every step writes a stamp holding the hash of its inputs and is skipped when
# the hash is unchanged, so a second run takes about a second.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
venv="$root/.venv"
stamps="$venv/.forte-stamps"
kit_prefix="$venv/opt/ros2_launch_kit"
packages=(forte_ros forte_msgs forte_description forte_driver forte_sim forte_perception forte_control forte_evaluation forte_bringup forte_commissioning)

say() { printf '[setup] %s\n' "$*"; }
die() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }
hash_of() { cat "$@" 2>/dev/null | sha256sum | cut -c1-16; }
stamp_ok() { [ -f "$stamps/$1" ] && [ "$(cat "$stamps/$1")" = "$2" ]; }
stamp_set() { mkdir -p "$stamps"; printf '%s' "$2" > "$stamps/$1"; }

launch_kit=${FORTE_LAUNCH_KIT:-}
while [ $# -gt 0 ]; do
  case "$1" in
    --launch-kit) [ $# -ge 2 ] || die "--launch-kit needs a folder"; launch_kit=$2; shift 2 ;;
    --launch-kit=*) launch_kit=${1#*=}; shift ;;
    -h|--help) sed -n '2,22p' "$0"; exit 0 ;;
    *) die "unknown argument: $1 (see tools/setup.sh --help)" ;;
  esac
done
if [ -n "$launch_kit" ]; then
  [ -d "$launch_kit/wheels" ] || die "--launch-kit $launch_kit: no wheels/ folder there"
  launch_kit=$(cd "$launch_kit" && pwd)
fi

command -v cmake >/dev/null || die "cmake not found (apt-get install cmake)"
command -v gcc >/dev/null || die "gcc not found (apt-get install build-essential)"

# 0. which machine: a sourced ROS 2 Jazzy first, whatever its Python -----------------------
use_system_ros=0
python_for_venv=${PYTHON:-python3}
if [ "${ROS_DISTRO:-}" = "jazzy" ]; then
  command -v "$python_for_venv" >/dev/null || die "ROS 2 Jazzy is sourced but $python_for_venv is not on PATH"
  "$python_for_venv" -c 'import rclpy' 2>/dev/null \
    || die "ROS_DISTRO=jazzy is set but $python_for_venv cannot import rclpy (source /opt/ros/jazzy/setup.bash in this shell, or set PYTHON to ROS's Python)"
  use_system_ros=1
  say "using the sourced ROS 2 Jazzy ($("$python_for_venv" --version 2>&1), AMENT_PREFIX_PATH=$AMENT_PREFIX_PATH)"
else
  command -v "$python_for_venv" >/dev/null || die "no $python_for_venv on PATH (Python 3.11 or 3.12 needed)"
  "$python_for_venv" -c 'import sys; sys.exit(sys.version_info[:2] not in ((3, 11), (3, 12)))' \
    || die "the ROS 2 Jazzy wheels exist for CPython 3.11 and 3.12; set PYTHON=python3.11"
fi
python_version=$("$python_for_venv" -c 'import sys; print("%d.%d" % sys.version_info[:2])')

# 1. virtual environment (recreated if it was made for the other kind of machine) ----------
if [ -x "$venv/bin/python" ] && ! stamp_ok machine "$use_system_ros-$python_version"; then
  say "the venv was made for another Python or machine kind: recreating it"
  rm -rf "$venv" "$root/build" "$root/install"
fi
if [ ! -x "$venv/bin/python" ]; then
  say "creating $venv (Python $python_version)"
  if [ $use_system_ros = 1 ]; then
    "$python_for_venv" -m venv --system-site-packages "$venv"
  else
    "$python_for_venv" -m venv "$venv"
  fi
  stamp_set machine "$use_system_ros-$python_version"
fi
pip=("$venv/bin/python" -m pip --disable-pip-version-check)
pip_quiet() { "${pip[@]}" install -q "$@" 2>&1 | grep -v -E "^WARNING: Location .* is ignored" || true; }

# 2. pinned dependencies ------------------------------------------------------------------
requirement_files=("$root/requirements/python.txt")
[ -f "$root/requirements/hardware.txt" ] && requirement_files+=("$root/requirements/hardware.txt")
[ $use_system_ros = 1 ] || requirement_files+=("$root/requirements/ros.txt")
if [ $use_system_ros = 0 ] || ! command -v colcon >/dev/null; then
  requirement_files+=("$root/requirements/colcon.txt")
fi
deps_hash=$(hash_of "${requirement_files[@]}" "$root/requirements/constraints.txt")
if ! stamp_ok deps "$deps_hash"; then
  say "installing pinned dependencies (first run: about a minute)"
  args=()
  for f in "${requirement_files[@]}"; do args+=(-r "$f"); done
  pip_quiet -c "$root/requirements/constraints.txt" "${args[@]}"
  "$venv/bin/python" -c 'import numpy, scipy, sklearn, serial, dynamixel_sdk, rosbags, mcap, pytest' \
    || die "dependency install failed (see pip output above)"
  stamp_set deps "$deps_hash"
fi

# The wheels' exported CMake files carry their build machine's paths (see shared notes):
# rewrite them to this venv's (after every install of ROS wheels).
fix_wheel_cmake_paths() {
  local include_dir site_dir f
  include_dir=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
  site_dir=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
  for f in "$venv"/share/*/cmake/export_*__rosidl_generator_pyExport.cmake; do
    [ -f "$f" ] || continue
    if grep -q '/opt/python/cp3' "$f"; then
      sed -i -E "s#/opt/python/cp3[0-9]+-cp3[0-9]+/include/python3\\.[0-9]+#$include_dir#g; \
                 s#/opt/python/cp3[0-9]+-cp3[0-9]+/lib/python3\\.[0-9]+/site-packages#$site_dir#g" "$f"
    fi
  done
}
[ $use_system_ros = 1 ] || fix_wheel_cmake_paths
# 4. bare machine with a launch kit: launch stack, ros2 CLI, two interface packages --------
# launch_ros's wheel requires the distribution `ament-index-python`, a name the package index
# does not have: the ROS wheels install that module as `ros-ament-index-python`. A
# metadata-only wheel of that name requiring ros-ament-index-python (tools/alias_wheel.py)
# satisfies pip, which otherwise reports the requirement as missing after every install.
ament_index_alias_wheel() {
  "$venv/bin/python" "$root/tools/alias_wheel.py" ament-index-python ros-ament-index-python \
    "$venv/opt/wheels"
}
if [ $use_system_ros = 0 ] && [ -n "$launch_kit" ]; then
  kit_hash=$(cd "$launch_kit" && find . -type f | sort | xargs sha256sum | sha256sum | cut -c1-16)
  kit_hash="$kit_hash-$(hash_of "$root/requirements/launch-kit.txt" "$root/requirements/constraints.txt")"
  if ! stamp_ok launch_kit "$kit_hash" || [ ! -d "$kit_prefix" ]; then
    say "installing the launch stack and ros2 CLI from $launch_kit"
    pip_quiet --no-deps "$launch_kit"/wheels/*.whl
    pip_quiet -c "$root/requirements/constraints.txt" -r "$root/requirements/launch-kit.txt" \
      "$(ament_index_alias_wheel)"
    fix_wheel_cmake_paths
    say "building composition_interfaces and control_msgs (about 4 minutes on 2 cores)"
    (
      export AMENT_PREFIX_PATH=$venv CMAKE_PREFIX_PATH=$venv PATH="$venv/bin:$PATH"
      mkdir -p "$venv/opt"
      cd "$venv"
      "$venv/bin/colcon" --log-base "$venv/opt/log" build --merge-install \
        --base-paths "$launch_kit/composition_interfaces" "$launch_kit/control_msgs" \
        --build-base "$venv/opt/build" --install-base "$kit_prefix" \
        --cmake-args -DBUILD_TESTING=OFF "-DPython3_EXECUTABLE=$venv/bin/python" \
        --event-handlers console_direct- summary+ > "$venv/opt/kit_build.log" 2>&1 \
        || { tail -40 "$venv/opt/kit_build.log" >&2; exit 1; }
    ) || die "launch kit interface build failed (log: .venv/opt/kit_build.log)"
    stamp_set launch_kit "$kit_hash"
  fi
fi
# (a venv whose launch kit was installed before the alias existed gets it here, once)
if [ $use_system_ros = 0 ] && [ -d "$kit_prefix" ] \
    && ! "$venv/bin/python" -c 'import importlib.metadata as m; m.version("ament-index-python")' \
    2>/dev/null; then
  pip_quiet -c "$root/requirements/constraints.txt" "$(ament_index_alias_wheel)"
fi

# 5. .venv/local_setup.bash: what a ROS install's setup script would set, for this venv. colcon
# finds it through AMENT_PREFIX_PATH and sources it from install/setup.bash (chaining).
kit_site="$kit_prefix/lib/python$python_version/site-packages"
for shell in bash sh; do
  {
    echo "# Generated by tools/setup.sh: the FORTE venv as an underlay of the colcon workspace."
    echo "export VIRTUAL_ENV=\"$venv\""
    echo "case \":\$PATH:\" in *\":$venv/bin:\"*) ;; *) export PATH=\"$venv/bin:\$PATH\" ;; esac"
    # on AMENT_PREFIX_PATH so that colcon chains this script from install/setup.bash (a
    # sourced ROS keeps its own entries after it); the wheels' share/ holds the ament index
    echo "export AMENT_PREFIX_PATH=\"$venv\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}\""
    if [ $use_system_ros = 0 ] && [ -d "$kit_prefix" ]; then
      echo "export AMENT_PREFIX_PATH=\"$kit_prefix:\$AMENT_PREFIX_PATH\""
      echo "export PYTHONPATH=\"$kit_site\${PYTHONPATH:+:\$PYTHONPATH}\""
      echo "export LD_LIBRARY_PATH=\"$kit_prefix/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}\""
      echo "export PATH=\"$kit_prefix/bin:\$PATH\""
    fi
    [ $use_system_ros = 1 ] || echo "export CMAKE_PREFIX_PATH=\"\$AMENT_PREFIX_PATH\""
    echo "export RMW_IMPLEMENTATION=\${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
  } > "$venv/local_setup.$shell"
done


# 6. the workspace: colcon build --symlink-install, as on a robot ---------------------------
# (symlinked sources need no rebuild; new files installed by CMake or setup.py do)
ws_hash=$(hash_of $(for p in "${packages[@]}"; do ls "$root/$p"/{setup.py,setup.cfg,package.xml,CMakeLists.txt} \
  "$root/$p"/msg/* "$root/$p"/srv/* "$root/$p"/action/* 2>/dev/null; done) \
  "$venv/local_setup.bash"; ls "$root"/forte_*/{launch,config}/* 2>/dev/null)
if ! stamp_ok workspace "$ws_hash" || [ ! -f "$root/install/setup.bash" ]; then
  say "colcon build --symlink-install (${packages[*]}; first run: about a minute)"
  (
    # shellcheck disable=SC1091
    source "$venv/local_setup.bash"
    colcon_bin=$(command -v colcon || true)
    [ -x "$venv/bin/colcon" ] && colcon_bin="$venv/bin/colcon"
    [ -n "$colcon_bin" ] || die "colcon not found"
    cd "$root"
    mkdir -p "$root/log"
    build() {
      "$colcon_bin" build --symlink-install --base-paths "${packages[@]}" \
        --cmake-args -DBUILD_TESTING=ON "-DPython3_EXECUTABLE=$venv/bin/python" \
        --event-handlers console_direct- summary+ > "$root/log/forte_build.log" 2>&1
    }
    # a file that moved to another package leaves a stale link in build/ that stops
    # colcon's symlink install ("can't copy ... doesn't exist"): build once more from scratch
    build || { say "colcon build failed; again from a clean build/ and install/"
               rm -rf "$root/build" "$root/install"; build; } \
      || { tail -40 "$root/log/forte_build.log" >&2; exit 1; }
  ) || die "colcon build failed (log: log/forte_build.log, log/latest_build/)"
  stamp_set workspace "$ws_hash"
fi

# 7. smoke check ----------------------------------------------------------------------------
(
  set +u
  # shellcheck disable=SC1091
  source "$root/install/setup.bash"
  set -u
  python -c 'import rclpy, forte_msgs.msg, forte_msgs.srv, forte_msgs.action, forte_ros, forte_driver, forte_sim, forte_perception, forte_control, forte_evaluation, forte_bringup, forte_commissioning' \
    || die "rclpy + the FORTE packages do not import after setup"
  if [ -d "$kit_prefix" ]; then
    python -c 'import launch, launch_ros, launch_pytest, control_msgs.action' \
      || die "the launch stack does not import after setup"
  elif ! python -c 'import launch_ros, launch_pytest' 2>/dev/null; then
    say "note: no launch_ros / launch_pytest here: the launch tests will skip (README: launch kit)"
  fi
)
say "ready: source install/setup.bash"
