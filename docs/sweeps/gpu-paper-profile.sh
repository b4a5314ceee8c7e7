#!/bin/bash
# Issue 27: the paper profile's timings on one GPU (benchmarks/paper_profile.py), as run through the
# device tool on 2026-11-26 (a lent H200/H100 with its own PyTorch; .whl carries the wheels its image
# lacks: zarr, numcodecs, google-crc32c, donfig, pydantic and their needs, for Python 3.12).
# The stores are the quick profile's (5,000-sample pools): the same 256 x 144 images and
# 3,000 / 500 / 1,000 / 500 splits as the paper profile's 200,000-sample pools.
set -uo pipefail
export PYTHONUNBUFFERED=1
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
echo "cores: $(nproc)"
synthcal() { python3 -c 'import sys; from synthcal.cli import main; sys.exit(main())' "$@"; }
time synthcal generate intersection-1 intersection-2 --profile quick --out /tmp/data --workers 16 --splits --quiet --yes || exit 1
time timeout "${PROFILE_TIMEOUT:-420}" python3 benchmarks/paper_profile.py --data /tmp/data \
    --datasets ${DATASETS:-intersection-1 intersection-2} --device cuda --epochs "${EPOCHS:-3}"
