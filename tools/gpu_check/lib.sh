# Functions of tools/gpu_check.sh (sourced; see there for the usage).
# shellcheck shell=bash

# The Debian packages the check build needs (tools/gpu_check/CMakeLists.txt):
# headers of Eigen and GLM, GoogleTest's source (built with the torch's C++
# ABI), Google Benchmark (headers, CMake files, the shared library).
GC_PACKAGES=(libeigen3-dev libglm-dev googletest libbenchmark-dev libbenchmark1debian)

gc_log() { printf '[gpu_check] %s\n' "$*" >&2; }
gc_die() { printf '[gpu_check] FAILED: %s\n' "$*" >&2; exit 1; }

# gc_prepare DIR: the .deb of every package in DIR (apt-get download, run in
# DIR). A package whose .deb is already there is not downloaded again, so a
# filled DIR works offline; a missing one that cannot be downloaded fails,
# naming it.
gc_prepare() {
  local dir=$1 pkg missing=()
  mkdir -p "$dir" || gc_die "prepare: cannot create $dir"
  for pkg in "${GC_PACKAGES[@]}"; do
    if compgen -G "$dir/${pkg}_*.deb" >/dev/null; then continue; fi
    if ! command -v apt-get >/dev/null; then missing+=("$pkg"); continue; fi
    if ! (cd "$dir" && apt-get download "$pkg" >"$dir/apt-$pkg.log" 2>&1); then
      missing+=("$pkg")
    fi
    rm -f "$dir/apt-$pkg.log"
  done
  if ((${#missing[@]})); then
    gc_die "prepare: cannot download ${missing[*]} into $dir (offline and not cached? run 'tools/gpu_check.sh --prepare $dir' on a machine with apt-get and a network)"
  fi
  gc_log "prepared $(find "$dir" -name '*.deb' | wc -l) packages in $dir: $(du -sh "$dir" | cut -f1)"
}

# gc_unpack DEBS DEST: every .deb of DEBS unpacked into DEST with dpkg -x
# (never into /); without dpkg, ar + tar do the same.
gc_unpack() {
  local debs=$1 dest=$2 deb pkg member
  mkdir -p "$dest"
  for pkg in "${GC_PACKAGES[@]}"; do
    deb=$(compgen -G "$debs/${pkg}_*.deb" | head -n 1)
    [[ -n $deb ]] || gc_die "unpack: no ${pkg}_*.deb in $debs (run tools/gpu_check.sh --prepare $debs)"
    if command -v dpkg >/dev/null; then
      dpkg -x "$deb" "$dest" || gc_die "unpack: dpkg -x $deb failed"
    else
      member=$(ar t "$deb" | grep '^data\.tar') || gc_die "unpack: $deb has no data.tar"
      case $member in
        *.xz) ar p "$deb" "$member" | tar -xJ -C "$dest" ;;
        *.zst) ar p "$deb" "$member" | tar --zstd -x -C "$dest" ;;
        *.gz) ar p "$deb" "$member" | tar -xz -C "$dest" ;;
        *) ar p "$deb" "$member" | tar -x -C "$dest" ;;
      esac || gc_die "unpack: ar/tar of $deb failed"
    fi
  done
}

# Summary rows: step | status | seconds | detail. Status is PASS, FAIL or
# NO-GPU (a GPU step that could not run: never counted as passed).
GC_ROWS=()
GC_FAILED=()
gc_row() {
  GC_ROWS+=("$(printf '%-14s %-7s %7s  %s' "$1" "$2" "$3" "$4")")
  [[ $2 == FAIL ]] && GC_FAILED+=("$1")
  printf '[gpu_check] %-14s %-7s %7ss  %s\n' "$1" "$2" "$3" "$4" >&2
}

# gc_run NAME LOG TIMEOUT CMD...: runs CMD with its output in LOG; sets
# GC_RC and GC_SECONDS.
gc_run() {
  local name=$1 log=$2 limit=$3 t0
  shift 3
  t0=$(date +%s%N)
  { echo "# $*"; } >"$log"
  timeout "$limit" "$@" >>"$log" 2>&1
  GC_RC=$?
  local ds=$((($(date +%s%N) - t0) / 100000000))
  GC_SECONDS="$((ds / 10)).$((ds % 10))"
  if ((GC_RC == 124)); then echo "# TIMED OUT after ${limit}s" >>"$log"; fi
  gc_log "$name: exit $GC_RC after ${GC_SECONDS}s (log $log)"
}

# gc_gtest_step NAME BINARY TIMEOUT [gtest args]: a GoogleTest program as one
# step. With a GPU every test must pass and none may be skipped; without one
# every test must be skipped (they say "no GPU" / "CUDA backend
# unavailable") and the row is NO-GPU.
gc_gtest_step() {
  local name=$1 bin=$2 limit=$3 log="$GC_OUT/logs/$1.log" xml="$GC_OUT/$1.xml"
  shift 3
  if [[ ! -x $bin ]]; then
    gc_row "$name" FAIL - "not built ($bin)"
    return
  fi
  gc_run "$name" "$log" "$limit" "$bin" --gtest_output="xml:$xml" "$@"
  local passed skipped failed
  # GoogleTest's closing lines: "[  PASSED  ] N tests.", "[  SKIPPED ] N
  # tests, listed below:", "[  FAILED  ] N tests, listed below:".
  passed=$(sed -n 's/^\[  PASSED  \] \([0-9]*\) tests\{0,1\}\..*/\1/p' "$log" | tail -n 1)
  skipped=$(sed -n 's/^\[  SKIPPED \] \([0-9]*\) tests\{0,1\}, listed below.*/\1/p' "$log" | tail -n 1)
  failed=$(sed -n 's/^\[  FAILED  \] \([0-9]*\) tests\{0,1\}, listed below.*/\1/p' "$log" | tail -n 1)
  passed=${passed:-0} skipped=${skipped:-0} failed=${failed:-0}
  if ((GC_HAVE_GPU)); then
    if ((GC_RC == 0 && skipped == 0 && passed > 0)); then
      gc_row "$name" PASS "$GC_SECONDS" "$passed tests passed"
    else
      gc_row "$name" FAIL "$GC_SECONDS" "exit $GC_RC: $passed passed, $failed failed, $skipped skipped (a skip with a GPU is a failure)"
    fi
  else
    local why
    why=$(grep -m 1 -o -E 'no GPU[^"]*|CUDA backend unavailable[^"]*' "$log" | head -n 1)
    if ((GC_RC == 0 && passed == 0 && skipped > 0)); then
      gc_row "$name" NO-GPU "$GC_SECONDS" "not run: $skipped tests skipped (${why:-no reason printed})"
    elif ((GC_RC == 0)); then
      gc_row "$name" NO-GPU "$GC_SECONDS" "not run on a GPU: $passed CPU-side tests passed, $skipped skipped (${why:-no GPU})"
    else
      gc_row "$name" FAIL "$GC_SECONDS" "exit $GC_RC without a GPU: $failed failed"
    fi
  fi
}

# gc_bench_step NAME BINARY TIMEOUT: the CUDA rasterizer benchmark (JSON
# into OUT_DIR); every case must run (none may report an error).
gc_bench_step() {
  local name=$1 bin=$2 limit=$3 log="$GC_OUT/logs/$1.log" json="$GC_OUT/$1.json"
  if [[ ! -x $bin ]]; then
    gc_row "$name" FAIL - "not built ($bin)"
    return
  fi
  if ((!GC_HAVE_GPU)); then
    # Still start it: every case must say why it cannot run.
    gc_run "$name" "$log" "$limit" "$bin" --benchmark_filter='/10000/640/480/0'
    if grep -q 'no GPU' "$log"; then
      gc_row "$name" NO-GPU "$GC_SECONDS" "not run: $(grep -m 1 -o "no GPU[^'\"]*" "$log")"
    else
      gc_row "$name" FAIL "$GC_SECONDS" "without a GPU the benchmark did not say 'no GPU' (exit $GC_RC)"
    fi
    return
  fi
  gc_run "$name" "$log" "$limit" "$bin" --benchmark_out="$json" --benchmark_out_format=json \
    --benchmark_counters_tabular=true
  local cases errors
  cases=$(grep -c '"run_name"' "$json" 2>/dev/null)
  errors=$(grep -c '"error_occurred": true' "$json" 2>/dev/null)
  if ((GC_RC == 0 && ${cases:-0} > 0 && ${errors:-1} == 0)); then
    gc_row "$name" PASS "$GC_SECONDS" "$cases cases (times and peak memory in $json)"
  else
    gc_row "$name" FAIL "$GC_SECONDS" "exit $GC_RC, ${cases:-0} cases, ${errors:-?} with errors"
  fi
}

gc_write_summary() {
  local file="$GC_OUT/summary.txt" row
  {
    echo "dypho tools/gpu_check.sh ($GC_MODE) $(date -u +%Y-%m-%dT%H:%M:%SZ)"
    echo "gpu: $GC_GPU_TEXT"
    echo "nvcc: $GC_NVCC_TEXT"
    echo "torch: $GC_TORCH_TEXT"
    echo "cuda architectures: $GC_ARCHS"
    echo
    printf '%-14s %-7s %7s  %s\n' step status seconds detail
    for row in "${GC_ROWS[@]}"; do echo "$row"; done
    echo
    if ((${#GC_FAILED[@]})); then
      echo "RESULT: FAILED (${GC_FAILED[*]})"
    elif ((!GC_HAVE_GPU)); then
      echo "RESULT: COMPILED, GPU STEPS NOT RUN (no GPU)"
    else
      echo "RESULT: PASSED"
    fi
  } >"$file"
  cat "$file" >&2
}
