#!/bin/bash
# Issue 27: `synthcal bench --device cuda` on one GPU, a cell the CPU sweep measured (intersection-2,
# step-by-step, Top-MSE, `sha2020` and `proposed`, five seeds, the rate grid; runs_thirteenth.csv), as run
# through the device tool on 2026-11-27 (twenty-first session). The image has its own Python 3.12 and PyTorch;
# .whl carries the wheels it may lack (not in git). Fetch them here, from the repository root:
#   for p in zarr==3.1.6 numcodecs==0.16.6 google-crc32c==1.9.0 donfig==0.8.1.post1 pydantic==2.14.4 \
#            pydantic_core==2.50.5 annotated-types==0.8.0 typing-inspection==0.4.5 typing_extensions==4.16.0 \
#            shapely==2.2.0 pandas python-dateutil six pytz tzdata tqdm pyyaml filelock; do
#     python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
#       --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 --platform manylinux2014_x86_64 -d .whl $p; done
# and carry .whl with the run (27 MB; scipy's 35 MB wheel would not fit the 64 MiB a run carries, and only
# `synthcal table` needs scipy: print the tables here from runs.csv when the image lacks it). The two runs:
#   OUT=$OUT WORKERS=10 BENCH_TIMEOUT=470 bash docs/sweeps/gpu-bench.sh                          # the device check
#   OUT=$OUT WORKERS=20 BENCH_TIMEOUT=370 TRAINING=end-to-end LOSSES="top-dice dice" bash docs/sweeps/gpu-bench.sh
# What comes back under $OUT: digest.txt (the store's SHA-256 over its data files: run the heredoc below on the
# CPU sweep's store, the same digest means the same images, homographies and splits), runs.csv (`synthcal table
# --layout runs`: the archive; docs/results/runs_twentyfirst_gpu.csv is the two runs' files joined) and
# results.tgz (the run folders, per-image scores included, without the stage cache). Other cells: DATASETS,
# STORES, ESTIMATORS and EXTRA (more bench options, e.g. EXTRA="--segmentation unet --config docs/sweeps/unet30w.yaml").
# The CPU sweep's stores (/work/sweep29/data, `generate --splits`, then `synthcal split` on each for the mixed
# dictionaries), files and SHA-256 by this script's digest:
#   intersection-1.zarr 822 d91be65846bcdb1671e106f41623df5d2627c174332fc037b561e54d0c71e3dd
#   intersection-2.zarr 812 9cd6d69ad182a65386dd37ef0d15bc4acc91ad5f62f686e1d24eb4f43ef3961e (the GPU's: the same)
#   intersection-3.zarr 812 6cfc003766498a1eefde723572344686fd5f4eb813e0cedde6dd8b43abbb34aa
#   intersection-4.zarr 822 56364aa5c6d74ca653bed3a08ab2714f91422d8fd2e5e1af0df18379fc8bc753
#   intersection-5.zarr 822 f0e6fc7361cf108c706c87e37a3c47a38461ce80d781415c69a46aeeff30f8c0
set -uo pipefail
export PYTHONUNBUFFERED=1
OUT=${OUT:-/tmp/out}
pip3() { python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site "$@"; }
pip3 --upgrade .whl/zarr-* .whl/numcodecs-* .whl/google_crc32c-* .whl/donfig-* .whl/pydantic-* .whl/pydantic_core-* \
    .whl/annotated_types-* .whl/typing_inspection-* .whl/typing_extensions-* .whl/shapely-* || exit 1
missing=$(python3 -c '
import importlib.util as u
wheels = {"pandas": "pandas python_dateutil six pytz tzdata", "scipy": "scipy", "tqdm": "tqdm", "yaml": "pyyaml",
          "filelock": "filelock"}
print(" ".join(w for m, w in wheels.items() if u.find_spec(m) is None))')
echo "modules the image lacks, installed from .whl: ${missing:-none}"
for w in $missing; do
    if compgen -G ".whl/$w-*" > /dev/null; then pip3 .whl/$w-* || exit 1; else echo "no wheel for $w"; fi
done
export PYTHONPATH=/tmp/site:$PWD
# the package's metadata, for its estimators' entry points (the image cannot `pip install -e .` offline)
python3 - <<'PY' || exit 1
import tomllib
from pathlib import Path
project = tomllib.loads(Path("pyproject.toml").read_text())["project"]
info = Path(f"/tmp/site/synthcal-{project['version']}.dist-info")
info.mkdir(parents=True, exist_ok=True)
(info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: synthcal\nVersion: {project['version']}\n")
(info / "entry_points.txt").write_text("".join(
    f"[{group}]\n" + "".join(f"{name} = {target}\n" for name, target in points.items())
    for group, points in project["entry-points"].items()))
PY
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
python3 -c 'import torch, numpy, cv2; print("torch", torch.__version__, "numpy", numpy.__version__, "cv2", cv2.__version__)'
echo "cores: $(nproc)"
printf '#!/bin/sh\nexec python3 -c "import sys; from synthcal.cli import main; sys.exit(main())" "$@"\n' > /tmp/synthcal
chmod +x /tmp/synthcal && export PATH=/tmp:$PATH  # a command, not a function: timeout runs it
DATASETS=${DATASETS:-intersection-2}
STORES=${STORES:-$DATASETS}  # a mixed-K dataset reads other scenes' stores: STORES="intersection-1 ... intersection-5"
todo=""; for store in $STORES; do [ -e "/tmp/data/$store.zarr" ] || todo="$todo $store"; done
if [ -n "$todo" ]; then
    time synthcal generate $todo --profile quick --out /tmp/data --workers 16 --splits --quiet --yes || exit 1
    # the mixed dictionaries are drawn from the stores beside a store: split again once all exist (as the CPU sweep did)
    [ "$(echo $STORES | wc -w)" -gt 1 ] && for store in $STORES; do synthcal split "/tmp/data/$store.zarr" > /dev/null || exit 1; done
fi
python3 - $(for store in $STORES; do echo "/tmp/data/$store.zarr"; done) <<'E' | tee "$OUT/digest.txt"
import hashlib, sys
from pathlib import Path
for store in map(Path, sys.argv[1:]):  # every data file but the JSON metadata (it records the software)
    digest = hashlib.sha256()
    files = sorted(p for p in store.rglob("*") if p.is_file() and p.suffix != ".json")
    for path in files:
        digest.update(str(path.relative_to(store)).encode())
        digest.update(path.read_bytes())
    print(store.name, len(files), digest.hexdigest())
E
time timeout "${BENCH_TIMEOUT:-400}" synthcal bench --datasets $DATASETS --estimator ${ESTIMATORS:-sha2020 proposed} ${EXTRA:-} \
    --training "${TRAINING:-step-by-step}" --loss ${LOSSES:-top-mse} --select learning_rate=1e-4,3e-4,1e-3 --patience 6 --data /tmp/data --results "$OUT/results" \
    --profile quick --quiet --yes --device cuda --workers "${WORKERS:-5}"
synthcal table "$OUT/results" --layout runs --format csv > "$OUT/runs.csv" || echo "table: see above (scipy?)"
tar czf "$OUT/results.tgz" -C "$OUT" --exclude=results/cache results && rm -rf "$OUT/results"  # the device tool returns files, not deep folders
