#!/usr/bin/env bash
# Creates .venv-scipy (outside the product) with scipy for scripts/peers/scipy_lsa.py.
set -euo pipefail
cd "$(dirname "$0")/../.."
python3 -m venv .venv-scipy
.venv-scipy/bin/pip install --quiet scipy numpy
echo "ok: .venv-scipy/bin/python scripts/peers/scipy_lsa.py out/study-instances/block_n1000.json"
