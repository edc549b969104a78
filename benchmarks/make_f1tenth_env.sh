#!/bin/sh
# The side venv for bench_kart.py's f1tenth_gym anchor, from a checkout of f1tenth/f1tenth_gym
# (main: f110_gym 0.2.1, built at 4fdb9c7) that you give; nothing is fetched but PyPI packages.
# f110_gym is not on PyPI and its setup.py pins gym 0.19 / numpy <= 1.22, which do not install
# on Python 3.11: it goes in with --no-deps beside the versions below, which do (its source
# unpatched). Editable (as its README says), because its maps are not package data: keep the
# checkout where it is. Its own venv, so gym and numba never enter kartci's.
#
#   benchmarks/make_f1tenth_env.sh CHECKOUT [VENV]     (VENV: ~/.cache/kartci/f1tenth-gym)
#   export KARTCI_F1TENTH_PYTHON=VENV/bin/python
set -eu
[ $# -ge 1 ] && [ -f "$1/gym/f110_gym/envs/f110_env.py" ] || {
    echo "usage: $0 CHECKOUT [VENV]: CHECKOUT is a checkout of f1tenth/f1tenth_gym (main)" >&2
    exit 2
}
checkout=$(cd "$1" && pwd)
venv=${2:-$HOME/.cache/kartci/f1tenth-gym}
"${PYTHON:-python3.11}" -m venv "$venv"
"$venv/bin/python" -m pip install -q \
    gym==0.26.2 gym-notices==0.1.0 cloudpickle==3.1.3 numpy==1.26.4 numba==0.68.1 \
    llvmlite==0.50.0 scipy==1.17.1 pyyaml==6.0.4 pillow==13.0.0 \
    pyglet==1.4.11 future==1.0.0 pyopengl==3.1.10
"$venv/bin/python" -m pip install -q --no-deps -e "$checkout"
"$venv/bin/python" -I "$(dirname "$0")/f1tenth_anchor.py" --steps 10 2>/dev/null
echo "export KARTCI_F1TENTH_PYTHON=$venv/bin/python"
