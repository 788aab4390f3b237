#!/usr/bin/env bash
# Creates a Python virtual environment, outside the product, holding PI's own
# GCS client (PIPython, from PyPI). It is used only to check that the GCS
# simulator (`nanopush rig sim-gcs`) answers the way PI's client expects; the
# product never depends on it.
#
# Usage: scripts/peers/setup-venv-pipython.sh [VENV_DIR]
#   VENV_DIR defaults to $NANOPUSH_PEERS_DIR/venv-pipython, and
#   NANOPUSH_PEERS_DIR defaults to ~/.cache/nanopush-peers.
set -euo pipefail

venv_dir="${1:-${NANOPUSH_PEERS_DIR:-$HOME/.cache/nanopush-peers}/venv-pipython}"
python="${PYTHON:-python3}"

if [[ ! -x "$venv_dir/bin/python" ]]; then
    echo "creating venv in $venv_dir"
    "$python" -m venv "$venv_dir"
fi
"$venv_dir/bin/python" -m pip install --quiet --upgrade pip
# PIPython's TCP/IP and serial interfaces are pure Python; pyserial comes with it.
"$venv_dir/bin/python" -m pip install --quiet "PIPython>=2.10"
"$venv_dir/bin/python" -c 'import pipython; print("PIPython", pipython.__version__)'
echo "venv ready: $venv_dir/bin/python"
