#!/usr/bin/env bash
# Create or update the project's virtual environment (.venv) with ROS 2 Jazzy from PyPI wheels.
#
# Steps, each skipped when a stamp file under .venv/ says it is up to date:
#   1. check the toolchain: Python 3.11 (the ROS wheels are cp311) with venv and headers,
#      C and C++ compilers, cmake >= 3.16, make;
#   2. create .venv with that Python;
#   3. install requirements.txt (every version pinned) when the file changed;
#   4. rewrite the build-machine paths the ROS wheels embed in .venv/share/*/cmake/*.cmake to
#      this interpreter's include dir and numpy's include dir (cheap; checked every run);
#   5. build the interface package msg_defs/ (ballscrew_twin_msgs) with plain cmake and install
#      it into .venv when msg_defs/ or the requirements changed;
#   6. `pip install --no-deps -e .` when the packaging files changed.
#
# Environment: PYTHON (interpreter to use, default python3),
# JOBS (parallel build jobs, default nproc). Works with no stdin (CI=true) and without root.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
PYTHON="${PYTHON:-python3}"
JOBS="${JOBS:-$(nproc 2>/dev/null || echo 2)}"
MSG_SRC="$ROOT/msg_defs"
MSG_BUILD="$ROOT/build/ballscrew_twin_msgs"
REQUIRED_PY="3.11"
MIN_CMAKE="3.16"
# Paths of the machine the ros-* wheels were built on, found in their CMake export files.
WHEEL_PY_INCLUDE="/opt/python/cp311-cp311/include/python3.11"
WHEEL_NUMPY_INCLUDE="/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"

START=$SECONDS
log() { printf '[setup %3ds] %s\n' "$((SECONDS - START))" "$*"; }
die() {
    printf '[setup] ERROR: %s\n' "$*" >&2
    exit 1
}

# A ROS Python process of another environment may have exported this guard (ros_wheels_bootstrapper);
# clear it so the .venv interpreter sets its own library path.
unset _ROS_WHEELS_BOOTSTRAP_COMPLETE || true
export PIP_NO_INPUT=1 PIP_DISABLE_PIP_VERSION_CHECK=1
if [[ "${CI:-}" == "true" || ! -t 1 ]]; then
    export PIP_PROGRESS_BAR=off
fi

# pip, quiet, without the machine's notes about configured local index folders that do not exist
# ("WARNING: Location 'file:///...' is ignored"); pip's exit status is kept (pipefail).
pip_quiet() {
    "$VENV/bin/python" -m pip "$@" --quiet 2>&1 | { grep -v "^WARNING: Location 'file://" || true; }
}

# sha256 of stdin, first field only.
hash_stdin() { sha256sum | cut -d' ' -f1; }
hash_files() { cat "$@" | hash_stdin; }
stamp_ok() { [[ -f "$1" && "$(cat "$1")" == "$2" ]]; }

# ----------------------------------------------------------------------------------------------
# 1. Toolchain
# ----------------------------------------------------------------------------------------------
check_toolchain() {
    command -v "$PYTHON" >/dev/null 2>&1 \
        || die "Python interpreter '$PYTHON' not found. Install CPython $REQUIRED_PY (e.g. 'pyenv install 3.11.7', or Debian/Ubuntu: apt-get install python3.11 python3.11-venv python3.11-dev) or set PYTHON=/path/to/python3.11."
    # One interpreter start (pyenv shims are slow): version, executable, venv, headers.
    local info ver exe has_venv has_headers
    info="$("$PYTHON" -c '
import importlib.util as u, os, sys, sysconfig
inc = os.path.join(sysconfig.get_paths()["include"], "Python.h")
venv = all(u.find_spec(m) is not None for m in ("venv", "ensurepip"))
print("%d.%d" % sys.version_info[:2], int(venv), int(os.path.isfile(inc)), sys.executable)
' 2>&1)" || die "'$PYTHON' does not run as a Python interpreter: $(head -n 3 <<<"$info" | tr '\n' ' ')"
    read -r ver has_venv has_headers exe <<<"$info"
    [[ "$ver" == "$REQUIRED_PY" ]] \
        || die "'$PYTHON' is Python $ver, but the ROS 2 Jazzy wheels on PyPI are built for CPython $REQUIRED_PY (cp311) only. Install Python $REQUIRED_PY (e.g. 'pyenv install 3.11.7', or apt-get install python3.11 python3.11-venv python3.11-dev) and run again with PYTHON=python3.11 if it is not the default python3."
    [[ "$has_venv" == 1 ]] \
        || die "Python $ver ($exe) has no 'venv'/'ensurepip' module: install python3.11-venv (Debian/Ubuntu)."
    [[ "$has_headers" == 1 ]] \
        || die "Python $ver ($exe) development headers (Python.h) not found: install python3.11-dev (Debian/Ubuntu). They are needed to build the message package."
    PYTHON="$exe"
    command -v cc >/dev/null 2>&1 \
        || die "No C compiler 'cc' found: install gcc (Debian/Ubuntu: apt-get install build-essential). It is needed to build the message package."
    command -v c++ >/dev/null 2>&1 \
        || die "No C++ compiler 'c++' found: install g++ (Debian/Ubuntu: apt-get install build-essential). It is needed to build the message package."
    command -v make >/dev/null 2>&1 \
        || die "'make' not found: install make (Debian/Ubuntu: apt-get install make)."
    command -v cmake >/dev/null 2>&1 \
        || die "'cmake' not found: install CMake >= $MIN_CMAKE (Debian/Ubuntu: apt-get install cmake). It is needed to build the message package."
    local cmver
    cmver="$(cmake --version | head -n1 | awk '{print $3}')"
    if [[ "$(printf '%s\n%s\n' "$MIN_CMAKE" "$cmver" | sort -V | head -n1)" != "$MIN_CMAKE" ]]; then
        die "cmake $cmver is too old: CMake >= $MIN_CMAKE is needed."
    fi
    log "toolchain: $exe (Python $ver), cc, c++, cmake $cmver"
}

# ----------------------------------------------------------------------------------------------
# 2. Virtual environment
# ----------------------------------------------------------------------------------------------
# True when the venv's scripts point at its current location (a moved or copied venv's
# scripts keep the old absolute path in their first line). Paths with spaces: not checked.
venv_in_place() {
    [[ "$VENV" == *" "* ]] && return 0
    [[ "$(head -n 1 "$VENV/bin/pip" 2>/dev/null)" == "#!$VENV/bin/python"* ]]
}

ensure_venv() {
    if [[ -x "$VENV/bin/python" ]]; then
        local vver
        if venv_in_place \
            && vver="$("$VENV/bin/python" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null)" \
            && [[ "$vver" == "$REQUIRED_PY" ]]; then
            return 0
        fi
        log "existing $VENV is broken, was moved, or is not Python $REQUIRED_PY: recreating it"
        rm -rf "$VENV"
    fi
    log "creating virtual environment $VENV"
    "$PYTHON" -m venv "$VENV"
}

# ----------------------------------------------------------------------------------------------
# 3. Pinned requirements
# ----------------------------------------------------------------------------------------------
install_requirements() {
    local want stamp="$VENV/.stamp-requirements"
    want="$(hash_files "$ROOT/requirements.txt")"
    if stamp_ok "$stamp" "$want"; then
        log "requirements: up to date"
        return 0
    fi
    log "requirements: installing requirements.txt (ROS 2 Jazzy wheels, numerics, tools; ~1 min)"
    rm -f "$stamp"
    pip_quiet install --requirement "$ROOT/requirements.txt" \
        || die "pip could not install requirements.txt (see pip's message above)."
    printf '%s' "$want" >"$stamp"
}

# ----------------------------------------------------------------------------------------------
# 4. Fix the wheels' CMake export files
# ----------------------------------------------------------------------------------------------
fix_cmake_paths() {
    local py_inc np_inc files
    py_inc="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
    np_inc="$("$VENV/bin/python" -c 'import numpy; print(numpy.get_include())')"
    [[ -f "$py_inc/Python.h" ]] || die "Python.h not found in $py_inc: install python3.11-dev."
    [[ -d "$np_inc/numpy" ]] || die "numpy headers not found in $np_inc."
    files="$(grep -rlF "/opt/python/cp311-cp311" "$VENV"/share/*/cmake/ 2>/dev/null || true)"
    if [[ -z "$files" ]]; then
        log "cmake exports: no build-machine paths left"
        return 0
    fi
    log "cmake exports: rewriting build-machine paths in $(wc -l <<<"$files") files"
    local f
    while IFS= read -r f; do
        # numpy's path first: it is longer and does not contain the other one.
        sed -i -e "s|$WHEEL_NUMPY_INCLUDE|$np_inc|g" -e "s|$WHEEL_PY_INCLUDE|$py_inc|g" "$f"
    done <<<"$files"
    if grep -rlF "/opt/python/cp311-cp311" "$VENV"/share/*/cmake/ >/dev/null 2>&1; then
        die "unknown build-machine paths remain in: $(grep -rlF /opt/python/cp311-cp311 "$VENV"/share/*/cmake/ | tr '\n' ' ')"
    fi
}

# ----------------------------------------------------------------------------------------------
# 5. Interface package ballscrew_twin_msgs
# ----------------------------------------------------------------------------------------------
build_messages() {
    local want stamp="$VENV/.stamp-msgs"
    want="$(
        {
            cat "$VENV/.stamp-requirements"
            (cd "$MSG_SRC" && find . -type f -print0 | LC_ALL=C sort -z | xargs -0 sha256sum)
        } | hash_stdin
    )"
    if stamp_ok "$stamp" "$want" \
        && [[ -d "$VENV/lib/python$REQUIRED_PY/site-packages/ballscrew_twin_msgs" ]]; then
        log "messages: ballscrew_twin_msgs up to date"
        return 0
    fi
    log "messages: building ballscrew_twin_msgs from msg_defs/ (~30 s)"
    rm -f "$stamp"
    rm -rf "$MSG_BUILD"
    mkdir -p "$MSG_BUILD"
    local blog="$MSG_BUILD/build.log"
    # The venv's bin first: rosidl generators run the venv's python and CLI tools.
    if ! (
        export PATH="$VENV/bin:$PATH"
        cmake -S "$MSG_SRC" -B "$MSG_BUILD" \
            -DCMAKE_BUILD_TYPE=Release \
            -DCMAKE_PREFIX_PATH="$VENV" \
            -DCMAKE_INSTALL_PREFIX="$VENV" \
            -DPython3_EXECUTABLE="$VENV/bin/python3" \
            -DBUILD_TESTING=OFF
        cmake --build "$MSG_BUILD" --parallel "$JOBS"
        cmake --install "$MSG_BUILD"
    ) >"$blog" 2>&1; then
        tail -n 40 "$blog" >&2
        die "building the message package failed; full log: $blog"
    fi
    printf '%s' "$want" >"$stamp"
}

# ----------------------------------------------------------------------------------------------
# 6. The project itself, editable
# ----------------------------------------------------------------------------------------------
install_project() {
    local want stamp="$VENV/.stamp-editable"
    want="$(hash_files "$ROOT/setup.py" "$ROOT/setup.cfg" "$ROOT/package.xml" "$ROOT/pyproject.toml" "$VENV/.stamp-requirements")"
    if stamp_ok "$stamp" "$want" && [[ -x "$VENV/bin/twin_node" ]]; then
        log "project: editable install up to date"
        return 0
    fi
    log "project: pip install --no-deps -e ."
    rm -f "$stamp"
    # --no-build-isolation: build with the pinned setuptools of .venv, no download, no resolution.
    pip_quiet install --no-deps --no-build-isolation --editable "$ROOT" \
        || die "pip install -e . failed (see pip's message above)."
    local script
    for script in twin_node twin_demo_commander ballscrew-twin; do
        [[ -x "$VENV/bin/$script" ]] || die "console script $VENV/bin/$script was not installed."
    done
    printf '%s' "$want" >"$stamp"
}

check_imports() {
    "$VENV/bin/python" -c 'import rclpy, numpy, numba, scipy, rosbags, ballscrew_twin_msgs.msg, ballscrew_twin' \
        || die "the environment does not import (rclpy, numpy, numba, scipy, rosbags, ballscrew_twin_msgs, ballscrew_twin); remove .venv and run 'make setup' again."
}

main() {
    cd "$ROOT"
    check_toolchain
    ensure_venv
    install_requirements
    fix_cmake_paths
    build_messages
    install_project
    check_imports
    log "done: environment ready in $VENV"
}

main "$@"
