#!/usr/bin/env bash
# The Python package's tests: builds the wheel (the `ci` profile, sharing the test
# command's build), installs it with its extras into a virtual environment this script
# makes (target/python-venv), and runs python/tests there.
#
#   bash tools/python_tests.sh            # everything: gymnasium, vector env, bindings, SB3, Ray
#   bash tools/python_tests.sh --core     # without the SB3 and Ray tests (no torch, no ray)
#
# A cold install of the extras (stable-baselines3 with torch, ray[rllib]) downloads about
# 3 GB and took 2 min 9 s on the 2-core CI machine (2026-11-26).
set -euo pipefail
cd "$(dirname "$0")/.."
core=false
[[ "${1:-}" == "--core" ]] && core=true
venv=target/python-venv
if [[ ! -x "$venv/bin/python" ]]; then
    python3 -m venv "$venv"
fi
py="$venv/bin/python"
"$py" -m pip install -q --upgrade pip "maturin>=1.9,<2"
rm -rf target/wheels/ci
"$venv/bin/maturin" build -q -m python/Cargo.toml --profile ci --out target/wheels/ci
wheel=$(ls target/wheels/ci/centaur-*.whl)
extras=test
$core || extras=test,sb3,ray
"$py" -m pip install -q --force-reinstall --no-deps "$wheel"
"$py" -m pip install -q "$wheel[$extras]"
args=(-q python/tests)
$core && args+=(--ignore=python/tests/extra)
# From the repository root: `import centaur` is the installed wheel, not python/centaur.
"$py" -m pytest "${args[@]}"
