#!/usr/bin/env bash
# Install everything rcmplan needs (system libraries for headless rendering, every pip extra)
# and run the whole check: ruff lint, ruff format check, mypy, pytest.
#
# The browser tests (tests/test_report_browser.py, tests/test_view_browser.py) open report.html
# and the 3D view in headless Chromium. As root with apt-get (CI) this script installs Chromium
# and they are required; otherwise they run when a Chromium is on PATH and are skipped, with a
# line saying so, when none is. RCMPLAN_REQUIRE_BROWSER=1 requires them whatever happens (their
# absence is then a failure); RCMPLAN_REQUIRE_BROWSER=0 never requires them.
#
# `bash scripts/check.sh --heavy` (or RCMPLAN_HEAVY_TESTS=1) also runs the heavy suites in
# full: the tests marked `heavy` (random interrupts of teleop sessions, an interrupted sweep
# resumed, the QP on the dynamic MuJoCo plant, the home search that finds none) and the
# generated-input suites with their full case counts (tests/heavy.py).
set -euo pipefail
cd "$(dirname "$0")/.."
for arg in "$@"; do
  case "$arg" in
    --heavy) export RCMPLAN_HEAVY_TESTS=1 ;;
    *) echo "check.sh: unknown argument $arg (valid: --heavy)" >&2; exit 2 ;;
  esac
done

# Headless MuJoCo rendering through EGL and Mesa (no GPU needed), and Chromium.
EGL_PACKAGES="libegl1 libegl-mesa0 libgl1-mesa-dri libgles2 chromium"
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  # shellcheck disable=SC2086
  if ! dpkg -s $EGL_PACKAGES >/dev/null 2>&1; then
    apt-get update -qq
    # shellcheck disable=SC2086
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      $EGL_PACKAGES >/dev/null
  fi
fi

python -m pip install -q --disable-pip-version-check -e ".[all,video,dev]"
echo "check.sh: install done at $SECONDS s"

export MUJOCO_GL="${MUJOCO_GL:-egl}"

# The names the browser tests look for.
chromium_on_path() {
  command -v chromium || command -v chromium-browser || command -v google-chrome
}
case "${RCMPLAN_REQUIRE_BROWSER:-}" in
  "")
    if browser="$(chromium_on_path)"; then
      export RCMPLAN_REQUIRE_BROWSER=1
      echo "check.sh: browser tests run with $browser (required)"
    else
      echo "check.sh: no Chromium on PATH (chromium, chromium-browser, google-chrome): the" \
        "browser tests are skipped. Run as root to install it with apt-get, or install" \
        "it; RCMPLAN_REQUIRE_BROWSER=1 makes its absence a failure."
    fi
    ;;
  0) unset RCMPLAN_REQUIRE_BROWSER ;;
  *) echo "check.sh: RCMPLAN_REQUIRE_BROWSER=$RCMPLAN_REQUIRE_BROWSER: browser tests required" ;;
esac

# numba compiles each kernel on its first call and caches it (`rcmplan._jit`). On a
# fresh clone that compile is most of the suite's CPU time, and two pytest workers would each
# compile the same kernels: so every loop's kernels compile first, in two processes at once
# (iRAM!S's, its curved needle's on both plants through one loop, and the subretinal episode's
# QP periods and iOCT B-scan; the arms' and their curved needle's: 170 and 162 s side by side
# in one measurement, alone on the machine), while ruff and mypy run, and the test workers
# load them.
# Each stage prints its wall time, measured from the start of this script.
trap 'kill $(jobs -p) 2>/dev/null || true' EXIT  # no compile left running if a check fails
took() { echo "check.sh: $1 done at $SECONDS s"; }
{ python -c "from rcmplan.warmup import compile_iramis_kernels as i, compile_curved_kernels as c, compile_subretinal_kernels as b; i(); c(('iramis',)); b()" && took "iRAM!S and subretinal kernels"; } &
iramis_kernels=$!
{ python -c "from rcmplan.warmup import compile_arm_kernels as a, compile_curved_kernels as c; a(); c(('arm',))" && took "arm kernels"; } &
arm_kernels=$!
python -m ruff check src tests benchmarks
python -m ruff format --check src tests benchmarks
python -m mypy
took "ruff and mypy"
wait "$iramis_kernels"
wait "$arm_kernels"

# One pytest worker per core, at most 4 (pytest-xdist), each taking whole files, the longest
# first (tests/conftest.py: RUN_FIRST), so that no worker is left alone with a long file at
# the end and no file's fixtures are built on two workers.
workers="$(python -c 'import os; print(min(4, len(os.sched_getaffinity(0))))')"
python -m pytest -q -n "$workers" --dist loadfile --no-loadscope-reorder
took "pytest"
