#!/usr/bin/env bash
# One-command setup of the FORTE workspace (called by `make setup`).
#
# Bare machine (no ROS install): creates .venv/, installs pinned ROS 2 Jazzy wheels and the
# Python dependencies, builds forte_msgs with plain cmake into install/, installs the four
# Python packages in editable mode and writes install/setup.bash.
# Sourced ROS 2 Jazzy (ROS_DISTRO=jazzy and rclpy importable): the venv sees the system
# site-packages, nothing ROS is pip-installed, forte_msgs builds against the sourced ROS.
#
# Idempotent: every step writes a stamp holding the hash of its inputs and is skipped when
# the hash is unchanged, so a second run takes about a second.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
venv="$root/.venv"
install="$root/install"
build="$root/build"
stamps="$venv/.forte-stamps"
python_for_venv=${PYTHON:-python3}

say() { printf '[setup] %s\n' "$*"; }
die() { printf '[setup] ERROR: %s\n' "$*" >&2; exit 1; }
hash_of() { cat "$@" 2>/dev/null | sha256sum | cut -c1-16; }
stamp_ok() { [ -f "$stamps/$1" ] && [ "$(cat "$stamps/$1")" = "$2" ]; }
stamp_set() { mkdir -p "$stamps"; printf '%s' "$2" > "$stamps/$1"; }

command -v "$python_for_venv" >/dev/null || die "no $python_for_venv on PATH (Python 3.11 needed)"
"$python_for_venv" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' \
  || die "the ROS 2 Jazzy wheels are built for CPython 3.11; set PYTHON=python3.11"
command -v cmake >/dev/null || die "cmake not found (apt-get install cmake)"
command -v gcc >/dev/null || die "gcc not found (apt-get install build-essential)"

use_system_ros=0
if [ "${ROS_DISTRO:-}" = "jazzy" ] && "$python_for_venv" -c 'import rclpy' 2>/dev/null; then
  use_system_ros=1
  say "using the sourced ROS 2 Jazzy install (AMENT_PREFIX_PATH=$AMENT_PREFIX_PATH)"
fi

# 1. virtual environment -------------------------------------------------------------------
if [ ! -x "$venv/bin/python" ]; then
  say "creating $venv"
  if [ $use_system_ros = 1 ]; then
    "$python_for_venv" -m venv --system-site-packages "$venv"
  else
    "$python_for_venv" -m venv "$venv"
  fi
fi
pip=("$venv/bin/python" -m pip --disable-pip-version-check)

# 2. pinned dependencies ------------------------------------------------------------------
requirement_files=("$root/requirements/python.txt")
[ -f "$root/requirements/hardware.txt" ] && requirement_files+=("$root/requirements/hardware.txt")
[ $use_system_ros = 1 ] || requirement_files+=("$root/requirements/ros.txt")
deps_hash=$(hash_of "${requirement_files[@]}" "$root/requirements/constraints.txt"; echo "$use_system_ros")
if ! stamp_ok deps "$deps_hash"; then
  say "installing pinned dependencies (first run: about a minute)"
  args=()
  for f in "${requirement_files[@]}"; do args+=(-r "$f"); done
  "${pip[@]}" install -q -c "$root/requirements/constraints.txt" "${args[@]}" 2>&1 \
    | grep -v -E "^WARNING: Location .* is ignored" || true
  "${pip[@]}" check >/dev/null 2>&1 || true
  "$venv/bin/python" -c 'import numpy, scipy, sklearn, serial, dynamixel_sdk, rosbags, mcap' \
    || die "dependency install failed (see pip output above)"
  stamp_set deps "$deps_hash"
fi

# 3. work around the wheels' hard-coded build paths (see shared notes) --------------------
if [ $use_system_ros = 0 ]; then
  include_dir=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
  site_dir=$("$venv/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
  for f in "$venv"/share/*/cmake/export_*__rosidl_generator_pyExport.cmake; do
    [ -f "$f" ] || continue
    if grep -q '/opt/python/cp311-cp311' "$f"; then
      sed -i "s#/opt/python/cp311-cp311/include/python3.11#$include_dir#g; \
              s#/opt/python/cp311-cp311/lib/python3.11/site-packages#$site_dir#g" "$f"
    fi
  done
  "$venv/bin/python" -c 'import rclpy' || die "rclpy does not import from the venv"
fi

# 4. forte_msgs ---------------------------------------------------------------------------
msgs_hash=$(hash_of "$root"/forte_msgs/CMakeLists.txt "$root"/forte_msgs/package.xml \
  "$root"/forte_msgs/msg/* "$root"/forte_msgs/srv/* "$root"/forte_msgs/action/* \
  "$root"/forte_msgs/forte_ros/*.py; echo "$use_system_ros")
if ! stamp_ok msgs "$msgs_hash" || [ ! -d "$install/share/forte_msgs" ]; then
  say "building forte_msgs (about 30 s)"
  # Rebuild in place: install/ stays importable for processes already using it
  # (`make clean` removes it for a from-scratch build).
  rm -rf "$build/forte_msgs"
  mkdir -p "$build/forte_msgs"
  prefix_path=$venv
  [ $use_system_ros = 1 ] && prefix_path=$AMENT_PREFIX_PATH
  (
    cd "$build/forte_msgs"
    export AMENT_PREFIX_PATH=$prefix_path CMAKE_PREFIX_PATH=${prefix_path//:/;} PATH="$venv/bin:$PATH"
    cmake "$root/forte_msgs" -DCMAKE_INSTALL_PREFIX="$install" -DBUILD_TESTING=OFF \
      -DPython3_EXECUTABLE="$venv/bin/python" > cmake.log 2>&1 \
      || { tail -30 cmake.log >&2; exit 1; }
    make -j"$(nproc)" install > make.log 2>&1 || { tail -30 make.log >&2; exit 1; }
  ) || die "forte_msgs build failed (logs in build/forte_msgs)"
  stamp_set msgs "$msgs_hash"
fi

# 5. the Python packages, editable ---------------------------------------------------------
python_packages=(forte_driver forte_perception forte_control forte_bringup)
pkgs_hash=$(hash_of $(for p in "${python_packages[@]}"; do echo "$root/$p/setup.py" "$root/$p/setup.cfg" "$root/$p/package.xml"; done))
if ! stamp_ok packages "$pkgs_hash"; then
  say "installing ${python_packages[*]} (editable)"
  for p in "${python_packages[@]}"; do
    "${pip[@]}" install -q --no-deps --no-build-isolation -e "$root/$p" 2>&1 \
      | grep -v -E "^WARNING: Location .* is ignored" || true
    (cd / && "$venv/bin/python" -c "import $p") || die "package $p did not install"
  done
  stamp_set packages "$pkgs_hash"
fi

# 6. install/setup.bash ---------------------------------------------------------------------
site_msgs="$install/lib/python3.11/site-packages"
mkdir -p "$install"
{
  echo "# Generated by tools/setup.sh: source it to use the FORTE workspace."
  if [ $use_system_ros = 1 ]; then
    echo "export AMENT_PREFIX_PATH=\"$install:$AMENT_PREFIX_PATH\""
  else
    echo "export AMENT_PREFIX_PATH=\"$install:$venv\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}\""
  fi
  echo "export PYTHONPATH=\"$site_msgs\${PYTHONPATH:+:\$PYTHONPATH}\""
  echo "export LD_LIBRARY_PATH=\"$install/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}\""
  # node executables live in <prefix>/lib/<package>/ (the layout `ros2 run` expects)
  echo "export PATH=\"$(for p in "${python_packages[@]}"; do printf '%s:' "$venv/lib/$p"; done)$venv/bin:\$PATH\""
  echo "export RMW_IMPLEMENTATION=\${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
  echo "export FORTE_ROOT=\"$root\""
} > "$install/setup.bash"

# 7. smoke check ----------------------------------------------------------------------------
(
  # shellcheck disable=SC1091
  source "$install/setup.bash"
  python -c 'import rclpy, forte_msgs.msg, forte_msgs.srv, forte_msgs.action' \
    || die "rclpy + forte_msgs do not import after setup"
)
say "ready: source install/setup.bash"
