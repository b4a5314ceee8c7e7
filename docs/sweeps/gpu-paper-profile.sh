#!/bin/bash
# Issue 27: the paper profile's timings on one GPU (benchmarks/paper_profile.py), as run through the
# device tool on 2026-11-26 (a lent H200/H100 with its own PyTorch; .whl carries the wheels its image
# lacks, for its Python 3.12; not in git). Fetch them here, from the repository root, before the run:
#   for p in zarr==3.1.6 numcodecs==0.16.6 google-crc32c==1.9.0 donfig==0.8.1.post1 pydantic==2.14.4 \
#            pydantic_core==2.50.5 annotated-types==0.8.0 typing-inspection==0.4.5 typing_extensions==4.16.0 shapely==2.2.0; do
#     python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
#       --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 -d .whl $p; done
# and carry .whl (15 MB) with the run.
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
