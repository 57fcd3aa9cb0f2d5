#!/bin/sh
# Hostile-input cases of `dypho` that need a dataset (issue 16); run by CTest
# (tests/hostile_cli.cmake). Usage: hostile_cli.sh DYPHO WORK_DIR CASE.
# Each case prints what it checks; CTest matches the lines.
set -u
dypho=$1 work=$2 case=$3
ds=$work/ds
run() { "$@"; echo "exit code $?"; }
case $case in
  setup)  # 10 frames, frame 9 truncated (frame index 8)
    rm -rf "$ds" && "$dypho" synth --out "$ds" --frames 10 --width 160 --height 120 || exit 1
    f=$(ls "$ds/rgb" | sed -n 9p)
    head -c 100 "$ds/rgb/$f" > "$work/cut.png" && mv "$work/cut.png" "$ds/rgb/$f" && echo "setup done" ;;
  map)
    rm -rf "$work/map"
    run "$dypho" map "$ds" --out "$work/map" --iterations 5 --final-iterations 5
    test -s "$work/map/map.ply" && test -s "$work/map/report.md" && echo "outputs written" ;;
  map-strict)
    rm -rf "$work/map_strict"
    run "$dypho" map "$ds" --out "$work/map_strict" --iterations 5 --final-iterations 5 --strict
    test -s "$work/map_strict/map.ply" && test -s "$work/map_strict/report.md" && echo "outputs written" ;;
  run)
    rm -rf "$work/run"
    run "$dypho" run "$ds" --out "$work/run" --poses gt --sequential
    test -s "$work/run/map.ply" && test -s "$work/run/report.md" && echo "outputs written" ;;
  run-strict)
    rm -rf "$work/run_strict"
    run "$dypho" run "$ds" --out "$work/run_strict" --poses gt --sequential --strict
    test -s "$work/run_strict/map.ply" && test -s "$work/run_strict/trajectory.txt" && echo "outputs written" ;;
  run-no-pose)  # a reused folder with an earlier run's outputs; poses that do not overlap
    out=$work/run_no_pose
    mkdir -p "$out" && echo "old" > "$out/report.md" && echo "old" > "$out/map.glb" && echo "mine" > "$out/notes.txt"
    printf '# timestamp tx ty tz qx qy qz qw\n5.0 0 0 0 0 0 0 1\n5.1 0 0 0 0 0 0 1\n' > "$work/far_poses.txt"
    run "$dypho" run "$ds" --out "$out" --poses "$work/far_poses.txt" --sequential
    for f in report.md map.glb map.ply map.splat trajectory.txt; do test -e "$out/$f" && echo "LEFT $f"; done
    test -e "$out/notes.txt" && echo "other files kept" ;;
  map-no-pose)
    out=$work/map_no_pose
    mkdir -p "$out" && echo "old" > "$out/report.md"
    printf '# timestamp tx ty tz qx qy qz qw\n5.0 0 0 0 0 0 0 1\n5.1 0 0 0 0 0 0 1\n' > "$work/far_poses.txt"
    run "$dypho" map "$ds" --out "$out" --poses "$work/far_poses.txt"
    for f in report.md map.ply trajectory.txt; do test -e "$out/$f" && echo "LEFT $f"; done; echo "checked" ;;
  track-into-dataset)
    before=$(cksum < "$ds/groundtruth.txt")
    run "$dypho" track "$ds" --out "$ds/groundtruth.txt"
    test "$before" = "$(cksum < "$ds/groundtruth.txt")" && echo "ground truth unchanged" ;;
  masks-into-dataset)
    run "$dypho" masks "$ds" --out "$ds/"
    test -e "$ds/overlays" && echo "WROTE INTO THE DATASET"; echo "checked" ;;
  score-no-frame)  # frames 3 to 3 at every 10th: nothing to score (it said "covers none of the 0 frames")
    rm -rf "$work/score_map"
    "$dypho" map "$ds" --out "$work/score_map" --iterations 5 --final-iterations 5 > /dev/null 2>&1
    run "$dypho" score "$work/score_map/map.ply" --dataset "$ds" --trajectory gt --first-frame 3 --max-frames 1 \
      --out "$work/score_out" ;;
  *) echo "unknown case $case"; exit 1 ;;
esac
