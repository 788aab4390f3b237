#!/usr/bin/env bash
# Creates scripts/peers/.venv with trackpy, the peer detector used for the
# side-by-side benchmark and for generating fixture reference CSVs.
# Runs outside the product: nanopush itself never needs Python.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
python3 -m venv "$here/.venv"
"$here/.venv/bin/pip" install --quiet --upgrade pip
"$here/.venv/bin/pip" install --quiet "trackpy==0.7" pillow tifffile
echo "trackpy venv ready: $here/.venv"
