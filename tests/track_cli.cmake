# `dypho track` in its threaded mode gives the same trajectory in two runs:
# the back end's results (local BA, loop closure on the synthetic loop)
# reach the live map a fixed number of frames after their keyframe, however
# busy the machine is. The second run is timed differently on purpose (a
# busy loop on one core beside it). Included from tests/CMakeLists.txt.
add_test(NAME TrackCli.ThreadedRunsGiveTheSameTrajectoryWithALoop
  COMMAND sh -c "set -e; d=$(mktemp -d); trap 'rm -rf $d' EXIT; \
$<TARGET_FILE:dypho> synth --out $d/loop --frames 200 --width 320 --height 240 --fps 15 --motion loop --walkers 0 >/dev/null; \
$<TARGET_FILE:dypho> track $d/loop --out $d/a.txt > $d/a.log 2>&1; \
( end=$(($(date +%s) + 60)); while [ $(date +%s) -lt $end ]; do :; done ) & busy=$!; \
$<TARGET_FILE:dypho> track $d/loop --out $d/b.txt > $d/b.log 2>&1; kill $busy 2>/dev/null || true; \
grep 'loops (threaded): 1 closed' $d/a.log; grep 'loops (threaded): 1 closed' $d/b.log; \
cmp $d/a.txt $d/b.txt && echo identical")
set_tests_properties(TrackCli.ThreadedRunsGiveTheSameTrajectoryWithALoop PROPERTIES TIMEOUT 300 ENVIRONMENT OMP_WAIT_POLICY=passive)
