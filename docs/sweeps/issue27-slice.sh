#!/bin/bash
# Issue 27's reproduction sweep as run on 2026-11-25 (docs/reproduction.md, "How it was run"). Run it from a folder
# holding data/ (the quick stores) and results/, with a frozen clone of synthcal: a run is reused only while the
# estimators', models' and training's code hash is unchanged, so later sessions must keep using the same clone.
# Resumable: bench reuses finished runs; kill it at any time and start it again.
# On a reset machine (the thirty-sixth session's way back to step 18, 2 min): git clone /work/main /work/sweep29/code &&
#   git -C /work/sweep29/code checkout e8eb178 && echo opencv-python-headless==5.0.0.93 > /tmp/cv.txt &&
#   PIP_CONSTRAINT=/tmp/cv.txt make -C /work/sweep29/code venv. OpenCV: e8eb178 asks only for >= 4.9, and pip takes
#   5.1.0.95 since 2026-12-02, whose bilinear RGB renders differ from 5.0.0.93's in 0.03 % of the image values, by at
#   most 2 levels (intersection-3's store, fifty-seventh session); class maps and homographies are byte-equal, so a
#   true-map run is the same under both, but a UNet reads the RGB: its cache key and weights differ. Step 45's UNets
#   (read by step 48 too) were trained on 5.1.0.95's renders, checked by their cache key (docs/sweeps/unet_key.py);
#   steps 46, 47 and 49 ran in the same unpinned venv. Step 50's, from the fifty-seventh session, on 5.0.0.93's
#   (main's pin, the constraint above; the clone's tests/generate/test_pipeline.py passes with it). Then in
#   /work/sweep29 step 0's generate for just the scenes the next step reads (seconds; the regenerated stores give the
#   archived run ids), the step itself in a script of its own under setsid nohup, and docs/sweeps/archive_runs.py for
#   its archive.
set -u
HERE=$(cd "$(dirname "$0")" && pwd)
cd "${SWEEP:-.}"
export OMP_NUM_THREADS=1
S=${SYNTHCAL:-synthcal}
SEL="--select learning_rate=1e-4,3e-4,1e-3 --patience 6"
COMMON="--data data --results results --profile quick --seeds 0-4 --quiet --yes"
step() { echo "=== $(date -u +%H:%M:%S) $*"; /usr/bin/time -f "wall %e s" "$@"; local rc=$?; echo "=== done $(date -u +%H:%M:%S) rc $rc"; }
# 0. the stores (seconds each; the family/heading/blank ones after intersection-1, then its mixed dictionaries)
step $S generate intersection-1 intersection-2 intersection-3 intersection-4 intersection-5 soccer worldcup2014 \
    --profile quick --out data --workers 2 --splits --quiet --yes
step $S generate intersection-1a intersection-1b intersection-1c intersection-1d intersection-1-turn0 \
    intersection-1-turn15 intersection-1-turn45 intersection-1-turn90 intersection-1-blank family-1 heading-0 \
    heading-15 heading-45 heading-90 blank-1 --profile quick --out data --workers 2 --splits --quiet --yes
# the mixed dictionaries of mixed-1/-4/-5, once all five intersections are beside each other
for k in 1 4 5; do step $S split data/intersection-$k.zarr; done
# 1. intersection-1, Top-MSE: every model and diagnostic
step $S bench --datasets intersection-1 --estimator sha2020 sha2020-ccbv proposed retrieved oracle-template template $SEL $COMMON --workers 2
step $S bench --datasets mixed-1 mixed-family-1 mixed-blank-1 --estimator template retrieved oracle-template $SEL $COMMON --workers 2
# 2. the heading sweep's diagnostics
step $S bench --datasets mixed-heading-0 mixed-heading-15 mixed-heading-45 mixed-heading-90 --estimator template retrieved oracle-template $SEL $COMMON --workers 2
# 3. the paper's one real dataset: World Cup 2014 (209 train / 186 test cameras); no validation set, so no
#    selection: the profile's one rate (1e-3), every epoch; then the same runs at the grid's other two rates, each
#    fixed (a sensitivity check, never a choice made on test), through a layered configuration
step $S bench --datasets worldcup2014 --estimator sha2020 proposed retrieved oracle-template template $COMMON --workers 2
for lr in 3.0e-4 1.0e-4; do
  printf 'profiles:\n  quick:\n    training:\n      learning_rate: %s\n' "$lr" > "lr$lr.yaml"
  step $S bench --config "lr$lr.yaml" --datasets worldcup2014 --estimator sha2020 proposed --data data \
      --results "results-wc14-lr$lr" --profile quick --seeds 0-4 --quiet --yes --workers 2
done
# ---- third session (2026-11-25 evening); NEW: a clone of main at or after the World Cup validation split and
#      osm rotation_deg (same estimator code hash as the frozen clone, so finished runs are reused) ----
NEW=${NEW:-$S}
# 4. MSE beside Top-MSE on intersection-1
step $S bench --datasets intersection-1 --estimator sha2020 proposed --loss mse $SEL $COMMON --workers 2
# 5. World Cup 2014 with a validation split carved from train_val (42 of 209 per seed). Its fixed-rate runs above
#    were moved out of results/ first (mkdir -p results-wc14-lr1e-3/runs; mv results/runs/worldcup2014_* there):
#    their table keys are the same as the new runs'. NEW records the 167-frame train set in the run ids.
step $NEW split data/worldcup2014.zarr --seeds 0-4 --validation 42
step $NEW bench --datasets worldcup2014 --estimator sha2020 proposed $SEL $COMMON --workers 2
step $NEW bench --datasets worldcup2014 --estimator template oracle-template $SEL $COMMON --workers 2
# 6. the real-junction mix: four Helsinki 4-leg junctions turned to intersection-1's axes (seconds to generate)
SYNTHCAL=$NEW BENCH=$S step bash "$HERE/osm-junctions.sh"
step $S bench --config osm.bench.yaml --datasets mixed-osm4-1 --estimator template oracle-template $SEL $COMMON --workers 2
# 7. UNet in the loop on intersection-1
step $S bench --datasets intersection-1 --estimator sha2020 proposed --segmentation unet $SEL $COMMON --workers 2
# 7b. the trained Siamese (retrieved) on World Cup 2014 and on the real-junction mix
step $NEW bench --datasets worldcup2014 --estimator retrieved $SEL $COMMON --workers 2
step $S bench --config osm.bench.yaml --datasets mixed-osm4-1 --estimator retrieved $SEL $COMMON --workers 2
# ---- 2026-11-25 (fourth session, 23:01): the most decisive cells first (2.7 h of the 2 cores left) ----
# 8. intersection-2, Top-MSE, with the cheap rows (35 min)
step $S bench --datasets intersection-2 --estimator sha2020 proposed retrieved oracle-template template --loss top-mse $SEL $COMMON --workers 2
# 9. the trained models on the same-layout family mix (23 min; sha2020 seeds 0-1 were done by the third session)
step $S bench --datasets mixed-family-1 --estimator sha2020 proposed retrieved $SEL $COMMON --workers 2
# 10. Top-Dice on intersection-1 (29 min)
step $S bench --datasets intersection-1 --estimator sha2020 proposed --loss top-dice $SEL $COMMON --workers 2
# 11. end-to-end, Top-MSE, on intersection-1 (estimated 39 min)
step $S bench --datasets intersection-1 --estimator sha2020 proposed --training end-to-end --loss top-mse $SEL $COMMON --workers 2
# ---- 2026-11-25 (fourth session) stopped here ----
# ---- 2026-11-26 (fifth session): the paper's cells on intersections 3-5 before sha2020-ccbv on intersection-2 ----
# 12. the trained models on the blank control and the paper's mix (retrieved trains each mix's Siamese at 3 rates)
step $S bench --datasets mixed-blank-1 mixed-1 --estimator sha2020 proposed retrieved $SEL $COMMON --workers 2
# 13a. intersection-2 with MSE
step $S bench --datasets intersection-2 --estimator sha2020 proposed retrieved oracle-template template --loss mse $SEL $COMMON --workers 2
# 13c. (run) each model's rate grid widened past its edge on intersection-2, Top-MSE, in results-grid (cache shared),
#      the two benches pinned to a core each; docs/sweeps/union_grid.py reads both folders
# mkdir -p results-grid && ln -sfn ../results/cache results-grid/cache
# G="--datasets intersection-2 --patience 6 --data data --results results-grid --profile quick --seeds 0-4 --quiet --yes --workers 1"
# taskset -c 0 $S bench $G --estimator proposed --select learning_rate=3e-5,1e-4,3e-4 &
# taskset -c 1 $S bench $G --estimator sha2020 --select learning_rate=3e-4,1e-3,3e-3; wait
# ---- 2026-11-26 (fifth session) stopped here (intersection-3 under way; finished runs are reused); the next slices, in this order ----
# 15a. intersections 3-5, Top-MSE
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator sha2020 proposed retrieved oracle-template template $SEL $COMMON --workers 2
# ---- 2026-11-26 (sixth session) stopped here (the matching-score step under way; finished runs are reused) ----
# 18. (sixth session) the matching-score claim: proposed with MSE matching beside its Top-MSE matching runs,
#     Top-MSE loss, intersection-1 and -2 (`synthcal table results --paired matching_score=top-mse matching_score=mse`)
step $S bench --datasets intersection-1 intersection-2 --estimator proposed --matching mse $SEL $COMMON --workers 2
# ---- 2026-11-26 (seventh session): step 18 done, 13b stopped in flight for the UNet cells below (19) ----
# 19. (seventh session) the UNet cells again, on main's code: the UNet keeps its best validation epoch under
#     patience, with 30 epochs as the ceiling; the class-weighted reading, then the paper's plain loss. A later
#     code than the frozen clone's (another code hash), so in folders of their own, the stage cache shared
#     (its keys are contents); configuration layers docs/sweeps/unet30w.yaml (30-epoch ceiling, class-weighted)
#     and docs/sweeps/unet30.yaml (the same, the paper's plain loss), copied beside the results folders
# mkdir -p results-unet2 results-unet2-plain && ln -sfn ../results/cache results-unet2/cache \
#     && ln -sfn ../results/cache results-unet2-plain/cache
# U="--datasets intersection-1 --estimator sha2020 proposed --segmentation unet $SEL --data data --profile quick \
#    --seeds 0-4 --quiet --yes --workers 2"
# step $S2 bench --config unet30w.yaml $U --results results-unet2
# step $S2 bench --config unet30.yaml $U --results results-unet2-plain
# ---- 2026-11-26 (eighth session): step 19's weighted reading done (5 seeds); its plain reading started beside
#      the weighted reading's last run (a lock-waiting run left a core idle), then runs alone ----
# ---- 2026-11-26 (ninth session): step 19's plain reading finished; step 20 started after it (finished runs and
#      cached UNets are reused when the machine stops it) ----
# 21. (ninth session, run before 20) the STN's epoch ceiling doubled, intersection-1, Top-MSE, true maps, both
#     models, on the true-map runs' frozen code (Siamese cached), in a folder of its own:
#     `synthcal table results-stn48 --against results --paired loss=top-mse loss=top-mse` isolates the ceiling
# mkdir -p results/cache results-stn48 && ln -sfn ../results/cache results-stn48/cache
# step $S bench --config stn48.yaml --datasets intersection-1 --estimator sha2020 proposed $SEL --data data \
#     --profile quick --seeds 0-4 --quiet --yes --workers 2 --results results-stn48
# 20. the UNet cells of intersection-2 on main's code, class-weighted under the 30-epoch ceiling (replaces
#     step 16 below): mkdir -p results-unet3 && ln -sfn ../results/cache results-unet3/cache
# step $S2 bench --config unet30w.yaml ${U/intersection-1/intersection-2} --results results-unet3
# ---- 2026-11-26 (tenth session): the results folders above were lost with the machine between sessions. A new
#      folder (results) and a clone of main e8eb178; the stores generated again (intersection-1..3: 17 s). After
#      each slice: `synthcal table results --layout runs --format csv > docs/results/runs_tenth.csv` (the runs
#      archive, which `synthcal table` reads in place of the folder) ----
# 22. end-to-end Top-MSE on intersection-2 (64 min), Dice on intersection-1 (48 min), and sha2020 on
#     intersection-1 Top-MSE again: the cell of report_iou.csv, a check that its figures reproduce
step $S bench --datasets intersection-2 --estimator sha2020 proposed --training end-to-end --loss top-mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-1 --estimator sha2020 proposed --loss dice $SEL $COMMON --workers 2
step $S bench --datasets intersection-1 --estimator sha2020 --loss top-mse $SEL $COMMON --workers 2
# ---- 2026-11-26 (tenth session) stopped here; next: Top-Dice on intersection-2, then 13b onwards ----
# 23. (eleventh session, the same clone and folder; archive docs/results/runs_eleventh.csv) Top-Dice and Dice on
#     intersection-2 (46 and 45 min; `synthcal table results --paired loss=top-dice loss=dice`), MSE on
#     intersection-3
step $S bench --datasets intersection-2 --estimator sha2020 proposed --loss top-dice $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator sha2020 proposed --loss dice $SEL $COMMON --workers 2
step $S bench --datasets intersection-3 --estimator sha2020 proposed --loss mse $SEL $COMMON --workers 2
# ---- 2026-11-26 (eleventh session) stopped here; next: 13b onwards. The trained models on mixed-osm4-1 (17) need
#      its stores: `SYNTHCAL=<main's synthcal> BENCH=$S bash docs/sweeps/osm-junctions.sh` in the sweep folder
#      (82 s at K = 4, eleventh session) ----
# 24. (twelfth session, the same clone and folder; archive docs/results/runs_twelfth.csv) the trained models on the
#     real-junction mix (17, moved up: 42 min), then intersection-4 with MSE (part of 15b: its runs are reused
#     there); intersection-4/-5's stores: `$S generate intersection-4 intersection-5 --profile quick --out data
#     --splits --quiet --yes` (20 s each), then `$S split data/intersection-4.zarr` for the mixes that need -5
step $S bench --config osm.bench.yaml --datasets mixed-osm4-1 --estimator sha2020 proposed template retrieved oracle-template $SEL $COMMON --workers 2
step $S bench --datasets intersection-4 --estimator sha2020 proposed --loss mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-5 --estimator sha2020 proposed --loss mse $SEL $COMMON --workers 2
# ---- 2026-11-26 (twelfth session) stopped here: step 24 done (42, 65 and 57 min; intersection-5 started beside
#      intersection-4's last run); 13b was started after it (finished runs are reused); next: 13b, then 15b ----
# 13b. (thirteenth session, the same clone and folder; archive docs/results/runs_thirteenth.csv) sha2020-ccbv on
#      intersection-2 (a baseline check already made on intersection-1), with sha2020 beside it: its Top-MSE runs on
#      intersection-2 were lost with the folders, and the report pairs within a folder; then proposed (started beside
#      the last sha2020-ccbv run) and the diagnostics, so the whole Top-MSE cell is in one folder again
step $S bench --datasets intersection-2 --estimator sha2020 sha2020-ccbv $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator proposed $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator retrieved oracle-template template $SEL $COMMON --workers 2
# ---- 2026-11-27 (thirteenth session) stopped here: 13b done (sha2020 + sha2020-ccbv 96 min, proposed 37 min beside
#      it); mixed-4/-5 were started after it (finished runs are reused); next: 15b, then 14 and 16 ----
# 15b. mixed-4/-5 on both losses (intersections 3-5 with MSE are done: step 23/24), then intersections 3-5 with
#      Top-MSE again (lost with the folders; only needed for pairing with new runs)
step $S bench --datasets mixed-4 mixed-5 --estimator sha2020 proposed retrieved oracle-template template --loss top-mse mse $SEL $COMMON --workers 2
# ---- 2026-11-27 (fourteenth session) stopped here: mixed-4 done (35 runs, archive docs/results/runs_fourteenth.csv;
#      sha2020 385-465 s/run, proposed 527-795 s/run beside it); mixed-5 under way (finished runs are reused) ----
# 15c. (fifteenth session) mixed-5 with Dice first: an experiment showed the MSE-type losses collapse there and Dice
#      does not (reproduction.md); Top-Dice after step 14
step $S bench --datasets mixed-5 --estimator sha2020 proposed --loss dice $SEL $COMMON --workers 2
# ---- 2026-11-27 (fifteenth session) stopped here: mixed-5 done with Top-MSE and MSE (35 runs) and sha2020 with Dice
#      (5 runs, 373-627 s/run), archive docs/results/runs_fifteenth.csv; proposed with Dice under way (842 s/run),
#      then 14, then mixed-5 Top-Dice, then 16 (finished runs are reused) ----
# ---- 2026-11-27 (sixteenth session): the proposed model's mixed-5 Dice runs done (628-1111 s/run), both models' Dice
#      runs archived together in docs/results/runs_sixteenth.csv; step 14 split so the new cells (MSE) come first ----
# 14. the rest of end-to-end and the Dice losses on intersection-1 and -2
step $S bench --datasets intersection-1 intersection-2 --estimator sha2020 proposed --training end-to-end --loss mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-1 intersection-2 --estimator sha2020 proposed --training end-to-end --loss top-mse $SEL $COMMON --workers 2
# ---- 2026-11-27 (sixteenth session) stopped here: end-to-end with MSE done on intersections 1 and 2 (20 runs,
#      552-783 s/run, archive docs/results/runs_sixteenth.csv); the Top-MSE end-to-end step below under way ----
# ---- 2026-11-27 (seventeenth session): the Top-MSE end-to-end step above done (intersection-1's 9 runs again,
#      509-984 s/run, archive docs/results/runs_seventeenth.csv); the sweep went on with 15d, then 16 ----
step $S bench --datasets intersection-1 intersection-2 --estimator sha2020 proposed --loss top-dice dice $SEL $COMMON --workers 2
# 15d. (fifteenth session) mixed-5 with Top-Dice
step $S bench --datasets mixed-5 --estimator sha2020 proposed --loss top-dice $SEL $COMMON --workers 2
# ---- 2026-11-27 (seventeenth session): 15d done (10 runs, 182-925 s/run, archive docs/results/runs_seventeenth.csv);
#      16 was started by mistake (the 10-epoch UNet; step 20 above replaces it) and stopped after 18 min with no
#      finished run; step 20 started at 12:41 in results-unet3 (under way at the stop; finished runs and cached
#      UNets are reused). A bench started by a backgrounded script ignores SIGINT: stop it with
#      `kill -TERM -- -PGID` on a sweep started under `setsid` ----
# ---- 2026-11-27 (eighteenth session): step 20 needs ~3 h more (15 UNets of 30 epochs, ~24 min each beside another
#      run), longer than a session had left, so whole cells went first: the `--loss top-dice dice` step above (its
#      only new cell, intersection-1's Top-Dice runs, 10 runs in 41 min, archive docs/results/runs_eighteenth.csv),
#      then 15e; step 20 after them ----
# 15e. mixed-4 with Dice (its Top-MSE and MSE runs are in results: step 15b)
step $S bench --datasets mixed-4 --estimator sha2020 proposed --loss dice $SEL $COMMON --workers 2
# ---- 2026-11-27 (eighteenth session): 15e done (10 runs in 40 min, archive docs/results/runs_eighteenth.csv);
#      step 20 (results-unet3) resumed at 14:45 ----
# ---- 2026-11-27 (nineteenth session): a new machine; the sweep folder was lost again (step 20's finished runs
#      with it: it had not finished in two sessions). A new clone of e8eb178 and the intersection-2 store (6 s);
#      step 20 now runs in seed slices that fit a session, each slice archived to
#      docs/results/runs_unet30w_intersection2.csv (the cell's one archive; a later slice appends its rows):
#      seeds 0-2 here, 3-4 next (the same clone commit, so the slices are one code). Seeds 0-2 done in 2 h 14 min (62-69
#      min per sha2020 run with its three UNets, 10-11 min per proposed run); seeds 3-4 next. Beside it,
#      15f (mixed-4 with Top-Dice) was started on the core step 20 seemed to leave idle and stopped after 25 min with
#      no run finished: in a fresh folder each mixed-4 run trains its Siamese at every rate first (6-18 min), and
#      step 20's next run was waiting on its seed's UNets, not idle ----
# step $S bench --config unet30w.yaml ${U/intersection-1/intersection-2} --seeds 0-2 --results results-unet3
# step $S bench --config unet30w.yaml ${U/intersection-1/intersection-2} --seeds 3-4 --results results-unet3
# ---- 2026-11-27 (twentieth session): the same machine and folder (/work/sweep29); step 20's seeds 3-4 done in
#      77 min alone on the two cores (4 runs, 4,638 s; appended to docs/results/runs_unet30w_intersection2.csv:
#      the cell is complete, five seeds). 15f started right after it, both cores ----
# 16. the UNet on intersection-2 at 10 epochs: replaced by step 20 (run in seed slices above), kept as a record
# step $S bench --datasets intersection-2 --estimator sha2020 proposed --segmentation unet $SEL $COMMON --workers 2
# 15f. mixed-4 with Top-Dice (the paper has it; after step 20's seeds 3-4)
step $S bench --datasets mixed-4 --estimator sha2020 proposed --loss top-dice $SEL $COMMON --workers 2
# ---- 2026-11-27 (twentieth session): 15f done (10 runs in 40 min, 259-626 s/run, the Siamese networks trained
#      afresh in /work/sweep29/results; archive docs/results/runs_twentieth.csv). Next: 15g and 15h below ----
# 15g. end-to-end with Top-Dice and Dice on intersections 1 and 2 (40 runs, ~2.5 h by bench's estimate: one dataset per session;
#      started 21:21 in the twentieth session in /work/sweep29/results, finished runs are reused)
step $S bench --datasets intersection-1 --estimator sha2020 proposed --training end-to-end --loss top-dice dice $SEL $COMMON --workers 2
# ---- 2026-11-27 (twenty-first session): the twentieth's bench died with its session after 2 runs; restarted
#      21:50 on the CPU for intersection-1. Intersection-2's 20 runs ran instead on a lent H200 in 358 s
#      (docs/sweeps/gpu-bench.sh with TRAINING=end-to-end LOSSES="top-dice dice" WORKERS=20; archive
#      docs/results/runs_twentyfirst_gpu.csv, beside the same script's device check on the Top-MSE cell) ----
# step $S bench --datasets intersection-2 --estimator sha2020 proposed --training end-to-end --loss top-dice dice $SEL $COMMON --workers 2
# ---- 2026-11-27 (twenty-first session): intersection-1's 20 runs done at 23:36 on the CPU (18 this session in
#      6,391 s; archive docs/results/runs_twentyfirst.csv); 15h started right after, in the same folder ----
# 15h. Dice on mixed-1 (~1 h), the mix where the Dice loss may change a verdict
step $S bench --datasets mixed-1 --estimator sha2020 proposed --loss dice $SEL $COMMON --workers 2
# ---- 2026-11-28 (twenty-second session): 15h's bench died with the twenty-first session after its 5 sha2020 runs;
#      restarted at 00:25, the proposed model's 5 runs done in 27 min (archive docs/results/runs_twentysecond.csv,
#      with the diagnostics of 15i, 64 s: the Siamese networks cached by 15h's runs) ----
# 15i. the template diagnostics on mixed-1 in the same folder (the report's "- retrieved" pairs need them there)
step $S bench --datasets mixed-1 --estimator retrieved oracle-template template $SEL $COMMON --workers 2
# 15j. Top-Dice and MSE on mixed-1 (~1 h each; Top-Dice done in 41 min in the twenty-second session, archived
#      with 15h; MSE in 38 min, the same archive)
step $S bench --datasets mixed-1 --estimator sha2020 proposed --loss top-dice $SEL $COMMON --workers 2
step $S bench --datasets mixed-1 --estimator sha2020 proposed --loss mse $SEL $COMMON --workers 2
# ---- 2026-11-28 (twenty-second session): 15h-15j done; mixed-1's Top-MSE runs (lost with the fourth session's
#      folder) would let Top-MSE - MSE pair on mixed-1: the next CPU candidate ----
# 15k. Top-MSE on mixed-1 again (started in the twenty-second session, its bench died after the 5 sha2020 runs)
step $S bench --datasets mixed-1 --estimator sha2020 proposed --loss top-mse $SEL $COMMON --workers 2
# ---- 2026-11-28 (twenty-third session): 15k done (the proposed model's 5 runs in 24 min; archived with 15h-15j in
#      docs/results/runs_twentysecond.csv). Next: end-to-end on the mixes, mixed-1 first ----
# 15l. end-to-end with Top-MSE and Dice on mixed-1 (~50 min each by bench's estimate)
step $S bench --datasets mixed-1 --estimator sha2020 proposed --training end-to-end --loss top-mse $SEL $COMMON --workers 2
# ---- 2026-11-28 (twenty-third session): Top-MSE end-to-end done (10 runs in 57 min; archive
#      docs/results/runs_twentythird.csv); Dice end-to-end not run: the session ran 15m instead ----
# step $S bench --datasets mixed-1 --estimator sha2020 proposed --training end-to-end --loss dice $SEL $COMMON --workers 2
# 15m. mixed-1 Top-MSE with the fits ranked by validation iou (main f93db1d or later; its own results folder, since
#      the runs differ from 15k's only in the selection score)
# step $S bench --datasets mixed-1 --estimator sha2020 proposed --loss top-mse $SEL --selection-score iou \
#      --data data --results results-iou --profile quick --quiet --yes --workers 2
# ---- 2026-11-28 (twenty-third session): 15m done (10 runs in 26 min; archive docs/results/runs_twentythird_iou.csv) ----
# 15n. the same ranking on a single scene: intersection-1 with Top-MSE (started 04:41 in the twenty-third session
#      in /work/sweep29/results-iou; finished runs are reused)
# step $S bench --datasets intersection-1 --estimator sha2020 proposed --loss top-mse $SEL --selection-score iou \
#      --data data --results results-iou --profile quick --quiet --yes --workers 2
# ---- 2026-11-28 (twenty-fourth session): 15n done (the proposed model's five runs in 31 min; archive
#      docs/results/runs_twentyfourth_iou.csv); 15l's second step (end-to-end Dice on mixed-1) done
#      (10 runs in 57 min; archive docs/results/runs_twentyfourth.csv) ----
# 15o. the same ranking on intersection-2 with Top-MSE (pairs with runs_thirteenth.csv, both models): done in the
#      twenty-fourth session (10 runs in 55 min; appended to docs/results/runs_twentyfourth_iou.csv)
# step $S bench --datasets intersection-2 --estimator sha2020 proposed --loss top-mse $SEL --selection-score iou \
#      --data data --results results-iou --profile quick --quiet --yes --workers 2
# ---- 2026-11-28 (twenty-fifth session; clone at e8eb178, results/) ----
# 15p. end-to-end Top-Dice on mixed-1: done (10 runs in 55 min; archive docs/results/runs_twentyfifth.csv)
step $S bench --datasets mixed-1 --estimator sha2020 proposed --training end-to-end --loss top-dice $SEL $COMMON --workers 2
# 15q. World Cup 2014, every loss step by step and end to end, on this clone (its store and splits from
#      `generate soccer worldcup2014 --splits`: 42 of the 209 train_val frames validate per seed)
for training in step-by-step end-to-end; do
  for loss in top-mse mse dice top-dice; do
    step $S bench --datasets worldcup2014 --estimator sha2020 proposed --training $training --loss $loss $SEL $COMMON --workers 2
  done
done
# ---- 15q: the four step-by-step cells and end-to-end Top-MSE, MSE and Dice done in the twenty-fifth session (70 runs
#      in 97 min; archive docs/results/runs_twentyfifth_worldcup.csv, with the template rows:
#      bench --datasets worldcup2014 --estimator retrieved oracle-template template $SEL $COMMON); Top-Dice end to end
#      was running at the stop; done in the twenty-sixth (its 8 unfinished runs in 19 min, rows added to the same
#      archive) ----
# 15r. end-to-end MSE on mixed-1
step $S bench --datasets mixed-1 --estimator sha2020 proposed --training end-to-end --loss mse $SEL $COMMON --workers 2
# ---- 15r: done in the twenty-sixth session (10 runs in 58 min; archive docs/results/runs_twentysixth.csv) ----
# 15s. the paper's matching table on World Cup 2014: the proposed model with MSE matching, every loss, step by step
#      then end to end (pairs with 15q's Top-MSE-matching runs: --paired matching_score=top-mse matching_score=mse)
step $S bench --datasets worldcup2014 --estimator proposed --training step-by-step --loss top-mse mse top-dice dice --matching mse $SEL $COMMON --workers 2
for loss in top-mse mse top-dice dice; do
  step $S bench --datasets worldcup2014 --estimator proposed --training end-to-end --loss $loss --matching mse $SEL $COMMON --workers 2
done
# ---- 15s: done in the twenty-sixth session (step by step 20 runs in 21 min, end to end 20 runs in 55 min; rows added
#      to docs/results/runs_twentyfifth_worldcup.csv) ----
# ---- 2026-11-28 (twenty-seventh session; clone at e8eb178, results/) ----
# 15t. Top-Dice step by step on intersections 3, 4 and 5 (the paper's models table; both models)
for dataset in intersection-3 intersection-4 intersection-5; do
  step $S bench --datasets $dataset --estimator sha2020 proposed --loss top-dice $SEL $COMMON --workers 2
done
# ---- 15t: done in the twenty-seventh session (10 runs in 49, 51 and 55 min; archive
#      docs/results/runs_twentyseventh.csv) ----
# ---- 2026-11-28 (twenty-eighth session; the machine was reset: the clone at e8eb178 made again, the stores regenerated
#      by step 0, a new results/) ----
# 15u. Dice step by step on intersections 3, 4 and 5 (pairs with 15t's Top-Dice runs: --paired loss=top-dice loss=dice)
for dataset in intersection-3 intersection-4 intersection-5; do
  step $S bench --datasets $dataset --estimator sha2020 proposed --loss dice $SEL $COMMON --workers 2
done
# ---- 15u: done in the twenty-eighth session (10 runs in 36, 35 and 34 min; archive
#      docs/results/runs_twentyeighth.csv) ----
# 15v. the matching table with Dice on intersections 3 and 4: the proposed model with MSE matching (pairs with 15u's
#      Top-MSE-matching runs: --paired matching_score=top-mse matching_score=mse)
for dataset in intersection-3 intersection-4; do
  step $S bench --datasets $dataset --estimator proposed --loss dice --matching mse $SEL $COMMON --workers 2
done
# ---- 15v: done in the twenty-eighth session (5 runs in 26 and 24 min; archive docs/results/runs_twentyeighth.csv) ----
# ---- 2026-11-28 (twenty-ninth session; the same clone, stores and results/) ----
# 15w. the matching table with Dice on intersection-5, then end to end with Top-MSE on intersections 3–5 (the cell's
#      claim, proposed − sha2020, pairs within the step; the step-by-step Top-MSE runs of the fifth and sixth sessions
#      survive only as docs/results/report_iou.csv's means, so end to end against step by step is unpaired there)
step $S bench --datasets intersection-5 --estimator proposed --loss dice --matching mse $SEL $COMMON --workers 2
for dataset in intersection-3 intersection-4 intersection-5; do
  step $S bench --datasets $dataset --estimator sha2020 proposed --training end-to-end --loss top-mse $SEL $COMMON --workers 2
done
# ---- 15w: intersection-5's matching cell done in the twenty-ninth session (5 runs in 34 min; appended to
#      docs/results/runs_twentyeighth.csv); end to end on intersections 3, 4 and 5 too (10 runs in 36 min each; archive
#      docs/results/runs_twentyninth.csv) ----
# ---- 2026-11-28 (thirtieth session; the same clone, stores and results/) ----
# 15x. end to end with Dice, then Top-Dice and MSE, on intersections 3–5: the cell's claim, proposed − sha2020, pairs
#      within the step, and end to end against step by step pairs with 15u's Dice, 15t's Top-Dice and the eleventh and
#      twelfth sessions' MSE runs (the same run ids: --against docs/results/runs_twentyeighth.csv, runs_twentyseventh.csv,
#      runs_eleventh.csv, runs_twelfth.csv --paired training=end-to-end training=step-by-step)
for loss in dice top-dice mse; do
  for dataset in intersection-3 intersection-4 intersection-5; do
    step $S bench --datasets $dataset --estimator sha2020 proposed --training end-to-end --loss $loss $SEL $COMMON --workers 2
  done
done
# ---- 15x: Dice on intersections 3, 4 and 5 and Top-Dice on intersection-3 done in the thirtieth session (10 runs in
#      35, 36, 38 and 38 min), Top-Dice on intersection-4 across the thirtieth and thirty-first (the last six runs in
#      23 min), Top-Dice on intersection-5 and MSE on intersections 3 and 4 in the thirty-first (34, 39 and
#      37 min), MSE on intersection-5 across the thirty-first and thirty-second (the last six runs in 24 min); appended to docs/results/runs_twentyninth.csv ----
# ---- 2026-11-29 (thirty-second session; the same clone, stores and results/) ----
# 15y. the paper's mixes for intersections 4 and 5 end to end, Dice first (the loss under which both STNs refine the
#      template step by step), then Top-Dice; each pairs with its step-by-step runs (mixed-4: runs_eighteenth.csv's
#      Dice, runs_twentieth.csv's Top-Dice; mixed-5: runs_sixteenth.csv's Dice, runs_seventeenth.csv's Top-Dice) through
#      --against ... --paired training=end-to-end training=step-by-step, and with the retrieved template
#      (runs_fourteenth.csv, runs_fifteenth.csv) through --paired proposed retrieved
for loss in dice top-dice; do
  for dataset in mixed-4 mixed-5; do
    step $S bench --datasets $dataset --estimator sha2020 proposed --training end-to-end --loss $loss $SEL $COMMON --workers 2
  done
done
# ---- 15y: mixed-4 with Dice and Top-Dice done in the thirty-second session (10 runs in 40 and 37 min; archive
#      docs/results/runs_thirtysecond.csv), mixed-5 with Dice after them (10 runs in 38 min, the same archive), and
#      mixed-5 with Top-Dice across the thirty-second and thirty-third (the last six runs in 24 min, the same archive) ----
# ---- 2026-11-29 (thirty-third session; the same clone, stores and results/) ----
# 15z. the rest of mixed-5 end to end (Top-MSE and MSE: 10 runs in 38 and 35 min, archive
#      docs/results/runs_thirtythird.csv), each pairing with runs_fifteenth.csv's step-by-step runs and retrieved
#      template; then mixed-4 end to end with Top-MSE (pairs with runs_fourteenth.csv) and the strongest public
#      baseline on the real data and on intersection-3, step by step with Top-MSE, sha2020 and proposed rerun beside it
#      so that the three pair by seed in one folder (World Cup 2014's pair too with runs_twentyfifth_worldcup.csv, the
#      same clone; intersection-3's with runs_twentyninth.csv's end-to-end Top-MSE runs)
for loss in top-mse mse; do
  step $S bench --datasets mixed-5 --estimator sha2020 proposed --training end-to-end --loss $loss $SEL $COMMON --workers 2
done
step $S bench --datasets mixed-4 --estimator sha2020 proposed --training end-to-end --loss top-mse $SEL $COMMON --workers 2
for dataset in worldcup2014 intersection-3; do
  step $S bench --datasets $dataset --estimator sha2020-ccbv sha2020 proposed --loss top-mse $SEL $COMMON --workers 2
done
# ---- 15z: mixed-5 Top-MSE and MSE and World Cup 2014 with sha2020-ccbv (15 runs in 10 min) done in the thirty-third
#      session (archive docs/results/runs_thirtythird.csv), and mixed-4 Top-MSE (10 runs in 38 min, the same archive);
#      intersection-3 with sha2020-ccbv, running at its stop, finished in the thirty-fourth (14 runs in 69 min, seed 0
#      of sha2020-ccbv 21 min before; archive docs/results/runs_thirtyfourth.csv) ----
# ---- 2026-11-29 (thirty-fourth session; the same clone, stores and results/) ----
# 16. the last end-to-end cell of the paper's mixes: mixed-4 with MSE (pairs with runs_fourteenth.csv's step-by-step runs)
#     and the strongest public baseline on intersection-4, as on intersection-3 (the three models side by side)
step $S bench --datasets mixed-4 --estimator sha2020 proposed --training end-to-end --loss mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-4 --estimator sha2020-ccbv sha2020 proposed --loss top-mse $SEL $COMMON --workers 2
# ---- 16: mixed-4 with MSE done in the thirty-fourth session (10 runs in 37 min; archive
#      docs/results/runs_thirtyfourth.csv); intersection-4 with sha2020-ccbv, running at its stop, finished in the
#      thirty-fifth (12 runs in 52 min; archive docs/results/runs_thirtyfifth.csv) ----
# ---- 2026-11-29 (thirty-fifth session; the same clone, stores and results/) ----
# 17. the strongest public baseline on intersection-5, the last of the paper's intersections
step $S bench --datasets intersection-5 --estimator sha2020-ccbv sha2020 proposed --loss top-mse $SEL $COMMON --workers 2
# ---- 17: done in the thirty-fifth session (15 runs in 71 min; archive docs/results/runs_thirtyfifth.csv) ----
# 18. the paper's matching table end to end, intersections 3–5 with Dice: the proposed model with MSE matching (pairs
#     with 15x's end-to-end Dice runs, Top-MSE matching, archive docs/results/runs_twentyninth.csv: --against ...
#     --paired matching_score=top-mse matching_score=mse), queued behind 17 in the thirty-fifth session
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator proposed --training end-to-end --loss dice --matching mse $SEL $COMMON --workers 2
# ---- 18: done in the thirty-sixth session on a reset machine (15 runs in 110 min, 773–857 s each; archive
#      docs/results/runs_thirtysixth.csv) ----
# ---- 2026-12-01 (thirty-sixth session; the machine was reset: the clone at e8eb178 made again, intersections 3-5's
#      stores regenerated — the runs' ids come out as archived —, a new results/) ----
# 19. the matching table step by step with Top-MSE on intersections 3-5: the proposed model with MSE matching (pairs
#     with the proposed runs of runs_thirtyfourth.csv and runs_thirtyfifth.csv: --paired matching_score=top-mse
#     matching_score=mse)
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator proposed --training step-by-step --loss top-mse --matching mse $SEL $COMMON --workers 2
# ---- 19: done over the thirty-sixth and thirty-seventh sessions (15 runs in 147 min of running, 891–1,498 s each;
#      the machine restarted between, finished runs reused; archive docs/results/runs_thirtyseventh.csv) ----
# 20. the same end to end (pairs with runs_twentyninth.csv's end-to-end Top-MSE runs, and with step 19's runs through
#     --paired training=end-to-end training=step-by-step)
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator proposed --training end-to-end --loss top-mse --matching mse $SEL $COMMON --workers 2
# ---- 2026-12-01 (thirty-seventh session; the same clone, stores and results/): 20 running at the stop, 21 and 22
#      queued behind it (/work/sweep29/sweep53.sh) — the cells of the paper's matching table with the largest
#      differences still unmeasured (its Top-MSE − MSE matching: Top-Dice step by step +4.08, +1.46, +1.71; MSE end to
#      end +3.08, +2.39, +2.10 on intersections 3, 4, 5) ----
# ---- 20: done over the thirty-seventh and thirty-eighth sessions (15 runs, 854–1,280 s each; the sweep died with the
#      session's end after six, the last nine in 79 min; archive docs/results/runs_thirtyeighth.csv) ----
# 21. the matching table step by step with Top-Dice on intersections 3-5: the proposed model with MSE matching (pairs
#     with the proposed runs of runs_twentyseventh.csv: --against ... --paired matching_score=top-mse matching_score=mse)
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator proposed --training step-by-step --loss top-dice --matching mse $SEL $COMMON --workers 2
# ---- 21: done over the thirty-eighth and thirty-ninth sessions (/work/sweep29/sweep54.sh, which replaced sweep53.sh;
#      15 runs, 698–1,393 s each; the sweep died with the thirty-eighth's end after seven, the last eight in 53 min;
#      archive docs/results/runs_thirtyninth.csv, intersections 4 and 5 appended with archive_runs.py) ----
# 22. the same end to end with MSE (pairs with runs_twentyninth.csv's end-to-end MSE runs)
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator proposed --training end-to-end --loss mse --matching mse $SEL $COMMON --workers 2
# ---- 2026-12-02 (thirty-ninth and fortieth sessions; the same clone, stores and results/): done (15 runs, 743–1,505 s
#      each; the sweep died with the thirty-ninth's end after 12, the last three in 32 min; archive
#      docs/results/runs_fortieth.csv, intersections 4 and 5 appended with archive_runs.py) ----
# 23. the matching table step by step with MSE on intersections 3-5: the proposed model with MSE matching (pairs with
#     the MSE proposed runs of runs_eleventh.csv and runs_twelfth.csv: --paired matching_score=top-mse
#     matching_score=mse; and with step 22 through --paired training=end-to-end training=step-by-step; paper -1.50,
#     -1.19, +0.46)
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator proposed --training step-by-step --loss mse --matching mse $SEL $COMMON --workers 2
# ---- 2026-12-02 (fortieth session; the same clone, stores and results/; /work/sweep29/sweep56.sh, sweep55.sh without
#      its wait, started beside step 22's last run): done (15 runs in 1 h 48 min, 693–958 s each; archive
#      docs/results/runs_fortyfirst.csv, one dataset at a time with archive_runs.py) ----
# ---- 2026-12-02 (forty-first session; the machine was reset: the clone at e8eb178 made again, intersections 3-5's
#      stores regenerated, a new results/; /work/sweep29/sweep57.sh) ----
# 24. the matching table end to end with Top-Dice on intersections 3-5: the proposed model with MSE matching (pairs
#     with runs_twentyninth.csv's end-to-end Top-Dice runs: --paired matching_score=top-mse matching_score=mse, paper
#     +1.68, +1.48, 0.00; and with step 21 through --paired training=end-to-end training=step-by-step)
step $S bench --datasets intersection-3 intersection-4 intersection-5 --estimator proposed --training end-to-end --loss top-dice --matching mse $SEL $COMMON --workers 2
# ---- 24: intersection-3 done in the forty-first session (5 runs, 1,016–1,059 s each; archive
#      docs/results/runs_fortysecond.csv, --where ... dataset=intersection-3); intersections 4 and 5 running at its end
#      (intersection-4's five finished there and were lost with the machine) ----
# ---- 2026-12-02 (forty-second session; the machine reset again: the same clone, stores of intersections 4-5
#      regenerated, /work/sweep29/sweep58.sh runs step 24 on intersections 4 and 5): done (intersection-4: 5 runs,
#      1,351-1,569 s each; intersection-5: 5 runs, 972-1,375 s; 10 runs in 1 h 43 min; each appended to
#      runs_fortysecond.csv with archive_runs.py ... dataset=intersection-N) ----
# ---- 2026-12-02 (forty-third session; the same machine, clone, stores and results/ as the forty-second;
#      /work/sweep29/sweep59.sh; lost with that session's machine) and 2026-12-03 (forty-fourth session, a reset
#      machine: the clone at e8eb178 made again, the stores of intersections 4 and 5 regenerated, a fresh cache; the
#      first try died in seconds on a dangling cache link, so results/cache is made first) ----
# 25. the STN's doubled ceiling (slice step 21's layer) on intersections 4 and 5, Top-MSE step by step, both models
#     (pairs with runs_thirtyfifth.csv, the same code at 24 epochs: --against ... --paired loss=top-mse
#     loss=top-mse per model); a folder of its own, the Siamese cache shared with results/
mkdir -p results/cache results-stn48 && ln -sfn ../results/cache results-stn48/cache && cp "$HERE/stn48.yaml" .
# one cell of both models under the doubled ceiling, on the frozen code (steps 25-27)
stn48_cell() { step $S bench --config stn48.yaml --datasets "$1" --estimator sha2020 proposed $SEL --data data \
    --profile quick --seeds 0-4 --quiet --yes --workers 2 --results results-stn48; }
for dataset in intersection-4 intersection-5; do stn48_cell $dataset; done
# 26. (forty-fifth session, a reset machine: the clone of e8eb178 again, intersection-2/-3 stores regenerated) the
#     STN's doubled ceiling on intersection-2 (pairs with runs_thirteenth.csv, the same code at 24 epochs), then, on a
#     clone of main (0c0556e, `--selection-score iou`), intersection-3 with the fits ranked by validation `iou`
#     (pairs with runs_thirtyfourth.csv); each in a folder of its own, the first in step 25's (made there)
stn48_cell intersection-2
# one cell of both models with the fits ranked by validation iou, on the clone of main (steps 26-28): DATASET [LOSS]
iou_cell() { step $NEW bench --datasets "$1" --estimator sha2020 proposed --loss "${2:-top-mse}" $SEL --selection-score iou \
    --data data --results results-iou --profile quick --seeds 0-4 --quiet --yes --workers 2; }
iou_cell intersection-3
# ---- 2026-12-03 (forty-fifth session): step 26 done: intersection-2 with 48 epochs in 76 min (archive
#      docs/results/runs_fortyfifth.csv), intersection-3 ranked by iou in 70 min (runs_fortyfifth_iou.csv) ----
# 27. (forty-sixth session, the same machine, clones, stores and folders as step 26, intersection-4's store made
#     with the clone of main) the STN's doubled ceiling on intersection-3 (pairs with runs_thirtyfourth.csv, the
#     same code at 24 epochs), then, on the clone of main, intersection-4 with the fits ranked by validation `iou`
#     (pairs with runs_thirtyfifth.csv)
stn48_cell intersection-3
iou_cell intersection-4
# ---- 2026-12-03 (forty-sixth session): step 27's first cell done in 86 min (archive docs/results/runs_fortysixth.csv);
#      intersection-4 ranked by iou in 69 min (archive docs/results/runs_fortysixth_iou.csv) ----
# 28. (forty-seventh session, a reset machine: a clone of main 95761fc, whose synthcal/ is 0c0556e's; the stores of
#     intersections 5 and 1 made with it, a fresh Siamese cache) intersection-5 with the fits ranked by validation
#     `iou` (pairs with runs_thirtyfifth.csv), then intersection-1 with Dice (pairs with runs_tenth.csv), chained
iou_cell intersection-5
iou_cell intersection-1 dice
# ---- 2026-12-04 (forty-seventh session): step 28 done: intersection-5 in 55 min, intersection-1 with Dice in 43 min
#      (archive docs/results/runs_fortyseventh_iou.csv, both cells) ----
# 29. (forty-seventh and forty-eighth sessions, the same clone, folder and cache as step 28) intersection-2 with Dice,
#     the fits ranked by validation `iou` (pairs with runs_eleventh.csv), then intersections 3 and 4 with Dice (pair
#     with runs_twentyeighth.csv), chained
iou_cell intersection-2 dice
iou_cell intersection-3 dice
iou_cell intersection-4 dice
# ---- 2026-12-04 (forty-eighth session): intersection-2 done (seven runs in the forty-seventh session, the last
#      three in 19 min; archive docs/results/runs_fortyseventh_iou.csv, appended); intersection-3 in 46 min,
#      intersection-4 in 42 min (the same archive) ----
# 30. (forty-ninth session, a reset machine: a clone of main 2c039bd, whose training code is 0c0556e's, at
#     /work/sweep29/code; intersection-5's store made with it, a fresh Siamese cache) step 29's last cell,
#     intersection-5 with Dice (pairs with runs_twentyeighth.csv)
iou_cell intersection-5 dice
# ---- 2026-12-04 (forty-ninth session): done in 40 min (archive docs/results/runs_fortyseventh_iou.csv, appended);
#      the selection score is measured on all five intersections with Top-MSE and Dice ----
# 31. (forty-ninth session, chained after step 30 on the same machine: the frozen clone e8eb178 made again at
#     /work/sweep29/frozen — OpenCV 5.1.0, which leaves true-map runs as they were —, intersection-1's store made with
#     it in /work/sweep29/fz, results folder results/) the matching table on intersection-1, Dice step by step: the
#     proposed model with MSE matching (pairs with runs_tenth.csv's Top-MSE-matching Dice runs: --against ...
#     --paired matching_score=top-mse matching_score=mse; paper +1.79)
step $S bench --datasets intersection-1 --estimator proposed --training step-by-step --loss dice --matching mse $SEL $COMMON --workers 2
# ---- 2026-12-04 (forty-ninth session): step 31 done in 34 min (5 runs, 600-942 s each; archive
#      docs/results/runs_fortyninth.csv) ----
# 32. (forty-ninth session, started at its stop in the same folder as step 31, /work/sweep29/run49c.sh) the matching
#     table on intersection-1, Top-Dice end to end (the paper's largest matching difference left there, +2.08): the
#     proposed model with MSE matching (pairs with runs_twentyfirst.csv's end-to-end Top-Dice runs: --against ...
#     --paired matching_score=top-mse matching_score=mse); if the machine survives, its runs are in fz/results
step $S bench --datasets intersection-1 --estimator proposed --training end-to-end --loss top-dice --matching mse $SEL $COMMON --workers 2
# ---- 2026-12-04 (fiftieth session): the machine kept /work/sweep29, but step 32's runs had died with the
#      forty-ninth session before any finished; rerun from 21:59 (same script, same folder) ----
# 33-35. (fiftieth session, chained behind step 32 in the same folder, /work/sweep29/run50.sh; intersection-2's store
#     made with the frozen clone in fz/data) the matching table on intersection-2, the proposed model with MSE
#     matching: Dice step by step (pairs with runs_eleventh.csv; paper +1.19), Top-MSE end to end (pairs with
#     runs_tenth.csv; paper +1.09), Top-Dice step by step (pairs with runs_eleventh.csv)
step $S bench --datasets intersection-2 --estimator proposed --training step-by-step --loss dice --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator proposed --training end-to-end --loss top-mse --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator proposed --training step-by-step --loss top-dice --matching mse $SEL $COMMON --workers 2
# ---- 2026-12-04 (fiftieth session): step 32 done in 28 min (5 runs, 463-764 s each; archive
#      docs/results/runs_fiftieth.csv) ----
# ---- 2026-12-04 (fiftieth session): step 33 (intersection-2, Dice step by step) done in 28 min (5 runs, 482-668 s
#      each; appended to docs/results/runs_fiftieth.csv) ----
# 36-40. (fiftieth session, chained behind steps 33-35 in the same folder, /work/sweep29/run50b.sh, left running at its
#     stop: runs that finish before the machine is reset stay in fz/results and bench reuses them) the matching
#     table's other true-map CPU cells, the proposed model with MSE matching: intersection-1 Top-Dice step by step
#     (pairs with runs_eighteenth.csv; paper +0.92), intersection-1 end to end with Dice (runs_twentyfirst.csv; +0.80),
#     Top-MSE (runs_seventeenth.csv; +0.31) and MSE (runs_sixteenth.csv; −0.04), intersection-2 end to end with MSE
#     (runs_sixteenth.csv; +0.22)
step $S bench --datasets intersection-1 --estimator proposed --training step-by-step --loss top-dice --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-1 --estimator proposed --training end-to-end --loss dice --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-1 --estimator proposed --training end-to-end --loss top-mse --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-1 --estimator proposed --training end-to-end --loss mse --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator proposed --training end-to-end --loss mse --matching mse $SEL $COMMON --workers 2
# ---- 2026-12-04 (fiftieth session): step 34 (intersection-2, Top-MSE end to end) done in 23 min (5 runs, 439-503 s
#      each, behind step 33 in the same cache; appended to docs/results/runs_fiftieth.csv) ----
# ---- 2026-12-04 (fiftieth session): step 35 (intersection-2, Top-Dice step by step) done in 21 min (5 runs, 369-543 s
#      each; appended to docs/results/runs_fiftieth.csv) ----
# ---- 2026-12-04 (fiftieth session): step 36 (intersection-1, Top-Dice step by step) done in 24 min (5 runs,
#      364-688 s each; appended to docs/results/runs_fiftieth.csv); steps 37-40 still running at the stop ----
# ---- 2026-12-05 (fifty-first session): the machine kept /work/sweep29; run50b.sh had died with the fiftieth session
#      after step 37's seeds 0 and 1; rerun from 00:24 (same script, same folder: bench reused step 36's runs and those
#      two seeds) ----
# ---- 2026-12-05 (fifty-first session): step 37 (intersection-1, Dice end to end) done, seeds 2-4 in 15 min (5 runs,
#      436-692 s each; appended to docs/results/runs_fiftieth.csv) ----
# ---- 2026-12-05 (fifty-first session): step 38 (intersection-1, Top-MSE end to end) done in 25 min (5 runs,
#      424-544 s each; appended to docs/results/runs_fiftieth.csv) ----
# ---- 2026-12-05 (fifty-first session): step 39 (intersection-1, MSE end to end) done in 23 min (5 runs,
#      417-509 s each; appended to docs/results/runs_fiftieth.csv) ----
# ---- 2026-12-05 (fifty-first session): step 40 (intersection-2, MSE end to end) done in 26 min (5 runs,
#      420-637 s each; appended to docs/results/runs_fiftieth.csv) ----
# 41-42. (fifty-first session, chained behind steps 37-40 in the same folder, /work/sweep29/run51.sh) the matching
#     table's step-by-step MSE cells of intersections 1 and 2: no Top-MSE-matching runs are archived there (lost with
#     the sixth session's folder), so both matchings run here
step $S bench --datasets intersection-1 --estimator proposed --training step-by-step --loss mse --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-1 --estimator proposed --training step-by-step --loss mse --matching top-mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator proposed --training step-by-step --loss mse --matching mse $SEL $COMMON --workers 2
step $S bench --datasets intersection-2 --estimator proposed --training step-by-step --loss mse --matching top-mse $SEL $COMMON --workers 2
# ---- 2026-12-05 (fifty-first session): step 41 (intersection-1) done in 41 min (10 runs, 297-578 s each; archive
#      docs/results/runs_fiftyfirst.csv); step 42 (intersection-2) still running at the stop ----
# ---- 2026-12-05 (fifty-second session): step 42 (intersection-2) done: its MSE-matching half in 22 min before the
#      fifty-first session's stop (5 runs, 402-626 s each), its Top-MSE half rerun from 03:01 in 27 min (5 runs,
#      507-584 s each); both appended to docs/results/runs_fiftyfirst.csv ----
# 43. (fifty-second session, chained behind step 42 in the same folder, /work/sweep29/run52.sh) intersection-2 end to
#     end with Dice and Top-Dice under both matchings: the archived Top-MSE-matching side ran on a GPU
#     (runs_twentyfirst_gpu.csv), so both sides run here, on one machine and one clone; Dice first
for loss in dice top-dice; do for matching in mse top-mse; do
  step $S bench --datasets intersection-2 --estimator proposed --training end-to-end --loss $loss --matching $matching $SEL $COMMON --workers 2
done; done
# ---- 2026-12-05 (fifty-second session): step 43's Dice halves done, MSE matching in 25 min (5 runs, 441-597 s each),
#      Top-MSE in 22 min (424-450 s each); archive docs/results/runs_fiftysecond.csv ----
# ---- 2026-12-05 (fifty-second session): step 43's Top-Dice half under MSE matching done in 29 min (5 runs, 471-649 s
#      each; appended to docs/results/runs_fiftysecond.csv) ----
# ---- 2026-12-05 (fifty-second session): step 43's Top-Dice half under Top-MSE matching done in 23 min (5 runs, 446-501
#      s each; appended): step 43 complete ----
# 44. (fifty-second session, started at its stop, /work/sweep29/run53.sh) the matching table's last true-map cells on
#     intersections 1 and 2, step by step with Top-MSE: the MSE-matching runs were lost with the sixth session's
#     folder, so both matchings run here, on one clone
for dataset in intersection-1 intersection-2; do for matching in mse top-mse; do
  step $S bench --datasets $dataset --estimator proposed --training step-by-step --loss top-mse --matching $matching $SEL $COMMON --workers 2
done; done
# ---- 2026-12-05 (fifty-third session): step 44 restarted at 05:37 in the same folder (run53.sh had died with the
#      fifty-second session; bench reused 4 finished runs): intersection-1 done, MSE matching 310-673 s a run,
#      Top-MSE matching 17 min (5 runs, 218-466 s each); archive docs/results/runs_fiftythird.csv; its runs equal the
#      lost sixth-session runs to the hundredth of a point ----
# ---- 2026-12-05 (fifty-third session): step 44 complete — intersection-2 MSE matching in 21 min (5 runs, 407-523 s
#      each), Top-MSE matching in 19 min (336-450 s each); appended to docs/results/runs_fiftythird.csv. Both halves equal
#      the lost sixth-session runs to the hundredth (not the thirteenth session's rerun of the Top-MSE-matching side).
#      With it every cell of the paper's matching table is measured on true maps; left for issue 27: the UNet in the
#      loop on intersections 3-5 (GPU only) ----
# 45. (fifty-third session, /work/sweep29/run55.sh in the same folder) the UNet in the loop on intersection-3, on the
#     CPU since no GPU was lent from the fiftieth session on: the cell of intersection-2's step 20 (class-weighted
#     UNet under the 30-epoch ceiling), in seed slices that fit a session; sha2020 first (it trains each seed's three
#     UNets, ~65 min a run), then the proposed model on the cached UNets; each slice appended to
#     docs/results/runs_unet30w_intersection3.csv (`--where dataset=intersection-3 segmentation=unet`; add
#     `loss=top-mse` once step 48's Top-Dice runs share the folder)
# unet_cell LOSS DATASET SLICE...: steps 45-50's cell on one intersection with one STN loss, each seed slice sha2020
# first, then the proposed model; the store first (seconds; it is reused when present)
unet_cell() {
  local loss=$1 dataset=$2 seeds estimator; shift 2
  [ -d "data/$dataset.zarr" ] || step $S generate "$dataset" --profile quick --out data --workers 2 --splits --quiet --yes
  for seeds in "$@"; do for estimator in sha2020 proposed; do
    step $S bench --estimator "$estimator" --seeds "$seeds" --datasets "$dataset" --segmentation unet \
        --loss "$loss" --config "$HERE/unet30w.yaml" $SEL --data data --results results --profile quick \
        --quiet --yes --workers 2
  done; done
}
unet_cell top-mse intersection-3 0-1 2-3 4
# ---- 2026-12-05 (fifty-third session): step 45's seeds 0-1 done in 52 min (sha2020 2,587-2,601 s a run with its
#      seed's three UNets, proposed 430-479 s; archive docs/results/runs_unet30w_intersection3.csv); seeds 2-3 started
#      at 07:40 (/work/sweep29/run56.sh), under way at the stop ----
# ---- 2026-12-05 (fifty-fourth session): seeds 2-3 (cut short by the fifty-third session's stop, restarted in the same
#      folder: bench reused the UNets cached before it) done in 36 min (sha2020 1,629-1,682 s, proposed 466-488 s),
#      appended to the archive (--expect 8); the UNets' per-class IoU (`synthcal segmentation`) written to
#      docs/results/unet30w_intersection3_segmentation.csv. Seed 4 started beside intersection-4's seed 0 (step 46),
#      two benches of one run each side by side. First with --workers 1, which this clone turns into two torch
#      threads a run (it sets OMP_NUM_THREADS to cores / workers, whatever the caller exported): 42 min of runs at
#      another thread count than every archived run, killed unfinished (the two match files they had cached
#      deleted), restarted with --workers 2, one thread a run ----
# ---- 2026-12-05 (fifty-fourth session): step 45 complete — seed 4 in 47 min (sha2020 2,382 s, proposed 447 s; the
#      archive holds 10 runs, --expect 10); intersection-4's seed 0 (step 46) finished beside it, not archived (one
#      seed gives no interval); seeds 1-2 started after it ----
# 46. (fifty-fourth session) the same cell on intersection-4, seed slices as step 45
unet_cell top-mse intersection-4 0 1-2 3-4
# ---- 2026-12-05 (fifty-fifth session): step 46's seeds 1-2 — sha2020 (2,239-2,462 s a run with its seed's UNets)
#      finished before the fifty-fourth session's stop, the proposed half (309-419 s) in this one, restarted in the
#      same folder; seeds 0-2 archived in docs/results/runs_unet30w_intersection4.csv (--expect 6); seeds 3-4 started
#      at 11:11 (/work/sweep29/run62.sh) ----
# ---- 2026-12-05 (fifty-fifth session): step 46 complete — seeds 3-4 in 47 min (sha2020 2,273-2,326 s, proposed
#      431-483 s); the archive holds 10 runs (--expect 10); the UNets' per-class IoU written to
#      docs/results/unet30w_intersection4_segmentation.csv ----
# 47. (fifty-fifth session, /work/sweep29/run63.sh in the same folder) the same cell on intersection-5, seed slices
#     0-1, 2-3, 4; each appended to docs/results/runs_unet30w_intersection5.csv (`--where dataset=intersection-5
#     segmentation=unet`); the true-map runs to pair with: runs_thirtyfifth.csv
unet_cell top-mse intersection-5 0-1 2-3 4
# ---- 2026-12-05 (fifty-fifth session): step 47's seeds 0-1 done in 56 min (sha2020 2,502-2,863 s, slowed by a fresh
#      clone's make test beside them; proposed 484-509 s); archived in docs/results/runs_unet30w_intersection5.csv
#      (--expect 4); seeds 2-3 started at 12:55 (/work/sweep29/run63.sh) ----
# ---- 2026-12-05 (fifty-sixth session): step 47 complete — seeds 2-3 (finished at the fifty-fifth session's stop) in
#      49 min (sha2020 2,330-2,465 s, proposed 453-467 s); seed 4, killed by that stop and rerun from 13:49 (run63.sh's
#      loop cut to seed 4) beside step 48, in 57 min (2,723 s, 681 s); the archive holds 10 runs (--expect 10); the
#      UNets' per-class IoU written to docs/results/unet30w_intersection5_segmentation.csv ----
# 48. (fifty-sixth session, /work/sweep29/run65.sh in the same folder, chained after step 47) the UNet in the loop
#     with Top-Dice step by step on intersection-3, the paper's largest step-by-step gain after intersection-2
#     (+7.67): the UNets step 45 cached are reused (a UNet's cache key holds no STN loss), so a run costs what a
#     proposed run of step 45 did; archive docs/results/runs_unet30w_topdice_intersection3.csv (`--where
#     dataset=intersection-3 segmentation=unet loss=top-dice`); the true-map runs to pair with: runs_twentyseventh.csv
unet_cell top-dice intersection-3 0-1 2-4
# ---- 2026-12-05 (fifty-sixth session): step 48 done in 45 min (run65.sh ran both models in one bench per seed slice,
#      0-1 beside step 47's seed 4, then 2-4; sha2020 401-456 s, proposed 517-700 s); archive
#      docs/results/runs_unet30w_topdice_intersection3.csv (--expect 10) ----
# 49. (fifty-sixth session, /work/sweep29/run66.sh, chained after step 48) Top-Dice on intersections 4 and 5 (paper
#     +1.35 and +1.80) on the UNets steps 46 and 47 cached; archives runs_unet30w_topdice_intersection{4,5}.csv
for dataset in intersection-4 intersection-5; do unet_cell top-dice $dataset 0-4; done
# ---- 2026-12-05 (fifty-sixth session): step 49's intersection-4 done in 33 min (run66.sh, one bench of both models,
#      seeds 0-4; sha2020 274-415 s, proposed 374-524 s); archive docs/results/runs_unet30w_topdice_intersection4.csv
#      (--expect 10) ----
# ---- 2026-12-05 (fifty-sixth session): step 49 complete — intersection-5 in 36 min (sha2020 279-410 s, proposed
#      385-519 s); archive docs/results/runs_unet30w_topdice_intersection5.csv (--expect 10) ----
# 50. (fifty-sixth session, /work/sweep29/run67.sh in the same folder, started 16:12) Dice step by step with the UNet on
#     intersections 3-5 (paper +0.75, +1.00, -2.20) on the UNets steps 45-47 cached, one bench of both models per
#     intersection; archives runs_unet30w_dice_intersection{3,4,5}.csv (`--where dataset=intersection-N
#     segmentation=unet loss=dice`); the true-map runs to pair with: runs_twentyeighth.csv. Under way at the
#     fifty-sixth session's stop (finished runs are reused)
for dataset in intersection-3 intersection-4 intersection-5; do unet_cell dice $dataset 0-4; done
# ---- 2026-12-05 (fifty-seventh session): the machine was reset between the sessions: step 50's runs and the UNets
#      steps 45-47 had cached were lost. The frozen clone rebuilt as the header says (OpenCV 5.0.0.93),
#      intersection-3's store regenerated, and step 50's intersection-3 run anew in seed slices, sha2020 training
#      each seed's three UNets again: `unet_cell dice intersection-3 0-1 2-3` (/work/sweep29/run69.sh) beside
#      `unet_cell dice intersection-3 4` (run70.sh), three runs on the two cores at first. Its UNets are not step
#      45's: a UNet cache key recomputed from step 50's seed-0 record gives the key step 45's run read
#      (0bd5f1ca..., docs/results/unet30w_intersection3_segmentation.csv) only on a store rendered under OpenCV
#      5.1.0.95, and the key the run recorded (443ae58c...) on 5.0.0.93's ----
# ---- 2026-12-05 (fifty-seventh session): step 50's intersection-3 seeds 0, 1 and 4 done by 18:28 (sha2020 4,275-4,741 s,
#      three runs on two cores; proposed 944-1,104 s); archived in docs/results/runs_unet30w_dice_intersection3.csv
#      (--expect 6); seeds 2-3 (run69.sh's second slice) under way at the stop ----
# ---- 2026-12-07 (fifty-eighth session): step 50's intersection-3 complete — seeds 2-3 (/work/sweep29/run71.sh, the
#      same rebuilt clone and folder, OpenCV 5.0.0.93): sha2020 two runs side by side in 75 min, proposed in 11 min;
#      appended to docs/results/runs_unet30w_dice_intersection3.csv (--expect 4; the archive holds 10 runs).
#      Intersections 4 and 5 with Dice (the rest of step 50's loop) not started: about 2 h a cell here ----
# 51. (fifty-eighth session, run71.sh, chained after step 50's seeds 2-3) sha2020 on intersection-2 end to end with
#     Dice and Top-Dice, on the CPU: the proposed side ran here in step 43, sha2020's only on a GPU
#     (runs_twentyfirst_gpu.csv), so every pair of the cell is now on one device; the store regenerated in the folder
#     (class maps, homographies and splits byte-equal whatever the OpenCV build)
for loss in dice top-dice; do
  step $S bench --datasets intersection-2 --estimator sha2020 --training end-to-end --loss $loss $SEL $COMMON --workers 2
done
# ---- 2026-12-07 (fifty-eighth session): step 51 done in 29 + 31 min (10 runs, 513-646 s each); archive
#      docs/results/runs_fiftyeighth.csv (`--where dataset=intersection-2 model=sha2020 training=end-to-end
#      loss=dice,top-dice --expect 10`) ----
# 52. (fifty-eighth session, /work/sweep29/run72.sh, a folder of its own, /work/sweep29/ulr, reading step 50's stores
#     through a link; main's code, not the frozen clone: training.unet_learning_rate exists only there) the proposed
#     model on intersection-3 with Dice on the UNet's maps, its UNet's rate fixed at 1e-3 (sweeps/unet30w_unetlr1e-3.yaml)
#     so that it reads the UNet sha2020 read on every seed: seeds 1-3, where it chose 3e-4 in step 50, tell the weaker
#     UNet's part of its cost from the model's; seeds 0 and 4, where it chose 1e-3, check that main's code gives step
#     50's runs. Started at 22:57, an hour before the session's stop: seeds 0-1 may finish, 2-4 not (≈ 28 min a run
#     two side by side, as its UNet trains again: the UNet cache key holds the code's hash)
step $NEW bench --estimator proposed --seeds 0-4 --datasets intersection-3 --segmentation unet --loss dice \
    --config "$HERE/unet30w_unetlr1e-3.yaml" $SEL --data data --results results --profile quick --quiet --yes --workers 2
