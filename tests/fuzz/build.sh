#!/bin/bash
# Builds the libFuzzer targets of tests/fuzz/fuzz_parsers.cc with clang,
# AddressSanitizer and UndefinedBehaviorSanitizer, from the parser sources
# only (no LibTorch, no CUDA), and their seed corpora.
#
#   tests/fuzz/build.sh BUILD_DIR            build the targets and seeds
#   tests/fuzz/build.sh BUILD_DIR run SECS   ... then fuzz each target SECS s
#                                            (a finding fails: exit code 1)
#
# Needs clang (Debian: apt-get install clang), libtinygltf-dev, libyaml-cpp-dev,
# nlohmann-json3-dev, zlib1g-dev, libdeflate-dev, libopencv-dev, libeigen3-dev, libglm-dev.
# A longer run of one target:
#   BUILD_DIR/fuzz_ply -max_total_time=3600 -dict=tests/fuzz/ply.dict BUILD_DIR/corpus/ply
set -euo pipefail
src=$(cd "$(dirname "$0")/../.." && pwd)
out=$(mkdir -p "$1" && cd "$1" && pwd)
mode=${2:-build}
secs=${3:-10}
jobs=${DYPHO_FUZZ_JOBS:-2}
cxx=${CXX_FUZZ:-clang++}

flags=(-std=c++17 -O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined,float-cast-overflow
       -fno-sanitize-recover=undefined -I"$src" -isystem /usr/include/eigen3 -isystem /usr/include/opencv4
       -DEIGEN_MAX_ALIGN_BYTES=16)
common=(common/check.cc common/logging.cc common/camera.cc common/rigid3.cc common/files.cc common/progress.cc)
exports=(engine/gaussians.cc engine/export/export.cc engine/export/ply.cc engine/export/ply_header.cc
         engine/export/splat.cc engine/export/spz.cc engine/export/gltf.cc)
dataset=(engine/dataset/dataset.cc engine/dataset/dataset_info.cc engine/dataset/camera_file.cc
         engine/eval/associate.cc engine/eval/trajectory.cc engine/io/image_io.cc engine/io/png_decode.cc
         $(cd "$src" && ls engine/stereo/*.cc | grep -v _test.cc))  # stereo folders: readers and disparity
options=(engine/pipeline/pipeline_options.cc engine/pipeline/pipeline_option_list.cc engine/pipeline/pipeline_presets.cc
         engine/pipeline/frame_depth_prior_options.cc engine/pipeline/config_tree.cc engine/map/mapper_options.cc engine/map/sensor_model.cc
         engine/synth/synth_options.cc tests/fuzz/options_stubs.cc)
libs_export=(-ltinygltf -lz)
libs_dataset=(-lyaml-cpp -ldeflate -lopencv_calib3d -lopencv_imgcodecs -lopencv_imgproc -lopencv_core)

# Objects, each compiled once (with -fsanitize=fuzzer-no-link: coverage for the
# fuzzer) and again when the source or any header it includes (the -MMD
# dependency file) is newer: a stale object built against an older header
# breaks the layout of a shared struct.
mkdir -p "$out/obj"
export src out cxx
export flags_str="${flags[*]}"
kernels=(kernels/rasterizer.cc kernels/cpu/cpu_rasterizer.cc kernels/cpu/cpu_forward.cc kernels/cpu/cpu_backward.cc)
all=("${common[@]}" "${exports[@]}" "${dataset[@]}" "${kernels[@]}")
all+=("${options[@]}")
printf '%s\n' "${all[@]}" | xargs -P "$jobs" -I{} bash -c 'flags=($flags_str -fopenmp); s={}; o="$out/obj/$(echo "$s" | tr / _).o";
  stale=0; [[ ! -f $o || ! -f $o.d || $src/$s -nt $o ]] && stale=1
  if [[ $stale == 0 ]]; then
    for dep in $(sed -e "s/^[^:]*://" -e "s/\\\\$//" "$o.d"); do [[ $dep -nt $o ]] && { stale=1; break; }; done
  fi
  if [[ $stale == 1 ]]; then "$cxx" "${flags[@]}" -fsanitize=fuzzer-no-link -MMD -MF "$o.d" -c "$src/$s" -o "$o"; fi'
objs() { for s in "$@"; do echo "$out/obj/$(echo "$s" | tr / _).o"; done; }

# name id sources... -- libs...
target() {
  local name=$1 id=$2
  shift 2
  local sources=() libs=()
  while [[ $# -gt 0 && $1 != -- ]]; do sources+=("$1"); shift; done
  [[ $# -gt 0 ]] && shift
  libs=("$@")
  rm -f "$out/fuzz_$name"
  "$cxx" "${flags[@]}" -fsanitize=fuzzer -DDYPHO_FUZZ_TARGET="$id" "$src/tests/fuzz/fuzz_parsers.cc" \
    $(objs "${common[@]}" "${sources[@]}") "${libs[@]}" -o "$out/fuzz_$name" &
}
target ply 1 "${exports[@]}" -- "${libs_export[@]}"
target splat 2 "${exports[@]}" -- "${libs_export[@]}"
target gltf 3 "${exports[@]}" -- "${libs_export[@]}"
wait
target glb 4 "${exports[@]}" -- "${libs_export[@]}"
target spz 5 "${exports[@]}" -- "${libs_export[@]}"
target camera 6 engine/dataset/camera_file.cc -- -lyaml-cpp
wait
target trajectory 7 engine/eval/trajectory.cc
target dataset 9 "${dataset[@]}" -- "${libs_dataset[@]}"
target options 8 "${options[@]}" -- -lyaml-cpp -lopencv_imgproc -lopencv_core
# The PNG target compiles the decoder itself without the CRC check (the
# fuzzer could not fix CRCs to reach the zlib stream and the filters).
rm -f "$out/fuzz_png"
"$cxx" "${flags[@]}" -fsanitize=fuzzer -DDYPHO_FUZZ_TARGET=10 -DFUZZING_BUILD_MODE_UNSAFE_FOR_PRODUCTION \
  "$src/tests/fuzz/fuzz_parsers.cc" "$src/engine/io/png_decode.cc" $(objs "${common[@]}") -ldeflate -o "$out/fuzz_png" &
wait
targets=(ply splat gltf glb spz camera trajectory dataset options png)
for t in "${targets[@]}"; do [[ -x $out/fuzz_$t ]] || { echo "fuzz_$t did not build"; exit 1; }; done

# The hostile-input unit tests of the parsers and the CPU rasterizer, built the
# same way (ASan and UBSan find what a plain build's test may not: a write
# one past a buffer).
"$cxx" "${flags[@]}" "$src/tests/hostile_parsers_test.cc" "$src/tests/test_main.cc" \
  -DDYPHO_SHARED_DATA="\"$src/../shared/data\"" -DDYPHO_BINARY_DIR="\"$out\"" \
  $(objs "${common[@]}" "${exports[@]}" "${dataset[@]}" "${options[@]}") "${libs_export[@]}" "${libs_dataset[@]}" \
  -lgtest -lpthread -o "$out/hostile_parsers_test_asan" &
"$cxx" "${flags[@]}" -fopenmp "$src/tests/hostile_raster_test.cc" "$src/tests/test_main.cc" \
  $(objs "${common[@]}" "${kernels[@]}") -lgtest -lpthread -o "$out/hostile_raster_test_asan" &
wait
for t in hostile_parsers_test_asan hostile_raster_test_asan; do [[ -x $out/$t ]] || { echo "$t did not build"; exit 1; }; done

# Seeds: dypho's own writers for the maps, hand-written files for the rest.
"$cxx" "${flags[@]}" "$src/tests/fuzz/fuzz_seeds.cc" $(objs "${common[@]}" "${exports[@]}") "${libs_export[@]}" \
  -o "$out/fuzz_seeds"
for t in "${targets[@]}"; do mkdir -p "$out/corpus/$t"; done
ASAN_OPTIONS=detect_leaks=0 "$out/fuzz_seeds" "$out/corpus"
cp "$src"/tests/fuzz/seeds/camera/* "$out/corpus/camera/"
cp "$src"/tests/fuzz/seeds/trajectory/* "$out/corpus/trajectory/"
cp "$src"/tests/fuzz/seeds/dataset/* "$out/corpus/dataset/"
cp "$src"/tests/fuzz/seeds/options/* "$out/corpus/options/"
cp "$src"/tests/fuzz/seeds/png/* "$out/corpus/png/"
echo "built ${#targets[@]} fuzz targets in $out"

[[ $mode == run ]] || exit 0
status=0
for t in hostile_parsers_test_asan hostile_raster_test_asan; do
  if ASAN_OPTIONS=detect_leaks=0 OMP_WAIT_POLICY=passive "$out/$t" > "$out/$t.log" 2>&1; then
    echo "$t: $(grep -E '^\[  PASSED  \]' "$out/$t.log")"
  else
    echo "$t: FINDING or failure, see $out/$t.log"; tail -40 "$out/$t.log"; status=1
  fi
done
for t in "${targets[@]}"; do
  dict=()
  d=$src/tests/fuzz/${t/glb/gltf}.dict
  [[ -f $d ]] && dict=(-dict="$d")
  mkdir -p "$out/findings/$t"
  log="$out/fuzz_$t.log"
  if ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1 "$out/fuzz_$t" -max_total_time="$secs" -timeout=10 \
      -rss_limit_mb=2048 -max_len=65536 -artifact_prefix="$out/findings/$t/" "${dict[@]}" "$out/corpus/$t" > "$log" 2>&1; then
    echo "fuzz_$t: $(grep -Eo 'Done [0-9]+ runs' "$log"), $(grep -Eo 'cov: [0-9]+ ft: [0-9]+' "$log" | tail -1), no finding in $secs s"
  else
    echo "fuzz_$t: FINDING, see $log and $out/findings/$t/"; tail -30 "$log"; status=1
  fi
done
exit $status
