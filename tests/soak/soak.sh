#!/usr/bin/env bash
# Soak test of `dypho run` (issue 16): the built-in sequence N times in a row
# in threaded mode, then one long built-in sequence; per run the peak RSS
# (GNU time), frames tracked of frames read and the keyframes dropped (always
# 0 by design) from metrics.json. Fails when a run exits non-zero, loses a
# frame, or when a run's peak RSS exceeds the first run's by more than 20 %.
# Usage: tests/soak/soak.sh BUILD_DIR OUT_DIR [RUNS=20] [LONG_FRAMES=3000]
set -euo pipefail
build="$1"; out="$2"; runs="${3:-20}"; long="${4:-3000}"
dypho="$build/tools/dypho"
mkdir -p "$out"
field() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }
first_rss=0; status=0
printf "run,seconds,peak_rss_mb,frames,tracked,keyframes,mapped\n" > "$out/soak.csv"
one() {  # name, extra args...
  local name="$1"; shift
  local dir="$out/$name"
  rm -rf "$dir"
  local start; start=$(date +%s.%N)
  if ! OMP_WAIT_POLICY=passive /usr/bin/time -f "%M" -o "$out/$name.rss" "$dypho" run --out "$dir" "$@" > "$out/$name.log" 2>&1; then
    echo "soak: $name failed, see $out/$name.log"; status=1; return
  fi
  local seconds; seconds=$(echo "$(date +%s.%N) - $start" | bc)
  local rss_mb=$(( $(tail -1 "$out/$name.rss") / 1024 ))
  local frames tracked kf mapped
  frames=$(field "$dir/metrics.json" frames); tracked=$(field "$dir/metrics.json" tracked)
  kf=$(field "$dir/metrics.json" keyframes); mapped=$(field "$dir/metrics.json" mapped_keyframes)
  printf "%s,%.1f,%d,%s,%s,%s,%s\n" "$name" "$seconds" "$rss_mb" "$frames" "$tracked" "$kf" "$mapped" >> "$out/soak.csv"
  echo "soak: $name ${seconds%.*} s, peak RSS $rss_mb MB, tracked $tracked/$frames, keyframes mapped $mapped/$kf"
  [ "$tracked" = "$frames" ] || { echo "soak: $name lost frames"; status=1; }
  [ "$mapped" = "$kf" ] || { echo "soak: $name left keyframes unmapped"; status=1; }
  if [ "$name" = run01 ]; then first_rss=$rss_mb
  elif [ "${name#run}" != "$name" ] && [ "$rss_mb" -gt $(( first_rss * 12 / 10 )) ]; then
    echo "soak: $name peak RSS $rss_mb MB grew beyond the first run's $first_rss MB + 20 %"; status=1
  fi
  rm -rf "$dir/overlays" "$dir/renders" "$dir/sequence"  # keep the disk bounded
}
for i in $(seq -w 1 "$runs"); do one "run$i"; done
[ "$long" -gt 0 ] && one long --set synth.frames="$long" --set synth.width=320 --set synth.height=240 --set overlay_every=0
echo "soak: $(if [ $status = 0 ]; then echo passed; else echo FAILED; fi); table in $out/soak.csv"
exit $status
