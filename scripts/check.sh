#!/usr/bin/env bash
# Install everything rcmplan needs (system libraries for headless rendering, every pip extra)
# and run the whole check: ruff lint, ruff format check, mypy, pytest.
set -euo pipefail
cd "$(dirname "$0")/.."

# Headless MuJoCo rendering through EGL and Mesa (no GPU needed), and Chromium for the tests
# that open report.html and the 3D view (`rcmplan view`, driven by playwright) in a real browser.
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

export MUJOCO_GL="${MUJOCO_GL:-egl}"
export RCMPLAN_REQUIRE_BROWSER="${RCMPLAN_REQUIRE_BROWSER:-1}"
python -m ruff check src tests benchmarks
python -m ruff format --check src tests benchmarks
python -m mypy
python -m pytest -q
