#!/usr/bin/env bash
# The CUDA path in one call: builds the CUDA backend and runs its checks on a
# machine with an NVIDIA GPU, nvcc, CMake, ninja and a Python with PyTorch,
# but no internet and no Debian development packages.
#
#   tools/gpu_check.sh --prepare [DIR]   on a normal machine (apt-get, network):
#                                        download the .debs the check build needs
#                                        into DIR (default gpu_check_debs/ in the
#                                        checkout, which git ignores)
#   tools/gpu_check.sh OUT_DIR           on the GPU machine: unpack the .debs
#                                        (dpkg -x into build-gpu-check/, never /),
#                                        build, run every step, write
#                                        OUT_DIR/summary.txt and OUT_DIR/logs/
#   tools/gpu_check.sh --dry-run OUT_DIR prepare (from the cache when offline),
#                                        configure and compile with nvcc; the GPU
#                                        steps report "no GPU" (exit 0)
#
# Steps (each a row of summary.txt: PASS, FAIL or NO-GPU):
#   build-cuda     tools/gpu_check/CMakeLists.txt: kernels + CUDA backend,
#                  cuda_parity_test, rasterizer_cuda_bench
#   build-torch    the same with engine/torch's op and the Mapper against the
#                  Python torch (torch.utils.cmake_prefix_path; fallback: its
#                  include and library paths), torch_rasterize_test,
#                  torch_cuda_test, mapper_cuda_test
#   parity         cuda_parity_test: CUDA vs CPU reference, outputs and every
#                  gradient (GPU)
#   bench          rasterizer_cuda_bench: 10k/100k/1M Gaussians at 640x480 and
#                  1920x1080, forward and forward+backward, peak memory (GPU)
#   torch-op       torch_cuda_test (gradcheck against double differences,
#                  parity with CPU tensors) + torch_rasterize_test (GPU)
#   mapping        mapper_cuda_test: the real Mapper with mapper.device=cuda
#                  against the same Mapper on the CPU (held-out PSNR, map size,
#                  every stage; it/s of both), and the mapper.device error
#                  without a GPU (GPU)
# Exit status: 0 when every step passed (dry run: when everything compiled);
# 1 when a step failed (summary.txt names it); 77 (dry run only) when there is
# no nvcc, so nothing could be checked.
#
# Environment: GPU_CHECK_DEBS (prepared folder), GPU_CHECK_WORK (unpacked
# packages and builds, default build-gpu-check/), GPU_CHECK_JOBS (build jobs,
# default nproc), GPU_CHECK_BUILD_TIMEOUT (seconds per build step, default
# 420, dry run 1500), PYTHON (default python3), DYPHO_CUDA_ARCHITECTURES (default auto:
# native with a GPU, else 75-real;80-real;86-real;89-real;90).
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
# shellcheck source=gpu_check/lib.sh
source "$ROOT/tools/gpu_check/lib.sh"

usage() { sed -n '2,21p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2; exit 2; }
GC_MODE=run
case ${1:-} in
  --prepare) gc_prepare "$(realpath -m "${2:-${GPU_CHECK_DEBS:-$ROOT/gpu_check_debs}}")"; exit 0 ;;
  --dry-run) GC_MODE=dry-run; shift ;;
  -h | --help | "") usage ;;
  -*) echo "unknown option $1" >&2; usage ;;
esac
[[ $# -eq 1 ]] || usage
GC_OUT=$(realpath -m "$1")
DEBS=$(realpath -m "${GPU_CHECK_DEBS:-$ROOT/gpu_check_debs}")
JOBS=${GPU_CHECK_JOBS:-$(nproc)}
PY=${PYTHON:-python3}
GC_ARCHS=${DYPHO_CUDA_ARCHITECTURES:-auto}
# Seconds per build step: 420 on the GPU machine (the whole run must fit in
# 8 minutes there), 1500 for a dry run on a small shared CI machine.
BUILD_LIMIT=${GPU_CHECK_BUILD_TIMEOUT:-$([[ $GC_MODE == dry-run ]] && echo 1500 || echo 420)}
mkdir -p "$GC_OUT/logs" || gc_die "cannot create $GC_OUT"
# Unpacked .debs and the two build folders: outside OUT_DIR (which holds only
# the summary and logs), kept for an incremental rerun.
WORK=$(realpath -m "${GPU_CHECK_WORK:-$ROOT/build-gpu-check}")
T_START=$(date +%s)

# --- The machine ------------------------------------------------------------
NVCC=$(command -v nvcc || true)
[[ -z $NVCC && -x /usr/local/cuda/bin/nvcc ]] && NVCC=/usr/local/cuda/bin/nvcc
GC_NVCC_TEXT=${NVCC:+$("$NVCC" --version | grep -m 1 -o 'release [0-9.]*') ($NVCC)}
GC_NVCC_TEXT=${GC_NVCC_TEXT:-none}
GC_HAVE_GPU=0
GC_GPU_TEXT="none (nvidia-smi -L lists no GPU)"
if command -v nvidia-smi >/dev/null && nvidia-smi -L >"$GC_OUT/logs/nvidia-smi.log" 2>&1 &&
  grep -q '^GPU ' "$GC_OUT/logs/nvidia-smi.log"; then
  GC_HAVE_GPU=1
  GC_GPU_TEXT=$(grep -m 1 '^GPU ' "$GC_OUT/logs/nvidia-smi.log")
  nvidia-smi >>"$GC_OUT/logs/nvidia-smi.log" 2>&1
fi
TORCH_PREFIX=$("$PY" -c 'import torch; print(torch.utils.cmake_prefix_path)' 2>/dev/null || true)
GC_TORCH_TEXT="none from $PY"
[[ -n $TORCH_PREFIX ]] && GC_TORCH_TEXT="$("$PY" -c 'import torch; print(torch.__version__, "cuda", torch.version.cuda, "cxx11_abi", int(torch._C._GLIBCXX_USE_CXX11_ABI))') ($TORCH_PREFIX)"
{
  echo "mode $GC_MODE, jobs $JOBS, cmake $(cmake --version | head -n 1), ninja $(ninja --version 2>&1)"
  echo "gpu $GC_GPU_TEXT"
  echo "nvcc $GC_NVCC_TEXT"
  echo "torch $GC_TORCH_TEXT"
  echo "c++ $(c++ --version | head -n 1)"
} >"$GC_OUT/logs/environment.log" 2>&1
if [[ -z $NVCC ]]; then
  if [[ $GC_MODE == dry-run ]]; then
    echo "SKIP: no nvcc on this machine (PATH or /usr/local/cuda/bin): the CUDA check build cannot be compiled" >&2
    exit 77
  fi
  gc_die "no nvcc (PATH or /usr/local/cuda/bin)"
fi
if [[ $GC_MODE == run && $GC_HAVE_GPU == 0 ]]; then
  gc_log "no GPU visible (nvidia-smi -L): building anyway; the GPU steps will be NO-GPU and the run FAILS"
fi

# --- Dependencies -----------------------------------------------------------
if [[ $GC_MODE == dry-run ]]; then
  ( gc_prepare "$DEBS" ) 2>"$GC_OUT/logs/prepare.log" || { cat "$GC_OUT/logs/prepare.log" >&2; exit 1; }
fi
rm -rf "$WORK/deps"
( gc_unpack "$DEBS" "$WORK/deps" ) 2>"$GC_OUT/logs/unpack.log" || { cat "$GC_OUT/logs/unpack.log" >&2; exit 1; }
gc_log "unpacked $(ls "$DEBS"/*.deb | wc -l) packages ($(du -sh "$DEBS" | cut -f1)) into $WORK/deps"

CMAKE_COMMON=(-G Ninja -DCMAKE_BUILD_TYPE=Release -DGC_DEPS_PREFIX="$WORK/deps"
  -DCMAKE_CUDA_COMPILER="$NVCC" -DDYPHO_CUDA_ARCHITECTURES="$GC_ARCHS")
if command -v ccache >/dev/null; then
  CMAKE_COMMON+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_CUDA_COMPILER_LAUNCHER=ccache)
fi

# --- build-cuda -------------------------------------------------------------
B1="$WORK/build_cuda"
gc_run build-cuda "$GC_OUT/logs/build-cuda.log" "$BUILD_LIMIT" bash -c \
  "cmake -S '$ROOT/tools/gpu_check' -B '$B1' $(printf '%q ' "${CMAKE_COMMON[@]}") && cmake --build '$B1' -j $JOBS"
if ((GC_RC == 0)); then
  GC_ARCHS=$(grep -m 1 -o 'dypho: CUDA architectures .*' "$GC_OUT/logs/build-cuda.log" | sed 's/dypho: CUDA architectures //')
  gc_row build-cuda PASS "$GC_SECONDS" "nvcc for $GC_ARCHS"
else
  gc_row build-cuda FAIL "$GC_SECONDS" "exit $GC_RC: $(grep -m 1 -E 'error|Error' "$GC_OUT/logs/build-cuda.log" | cut -c1-160)"
fi

# --- build-torch ------------------------------------------------------------
B2="$WORK/build_torch"
TORCH_ARGS=(-DGC_WITH_TORCH=ON)
[[ -n $TORCH_PREFIX ]] && TORCH_ARGS+=(-DCMAKE_PREFIX_PATH="$TORCH_PREFIX")
[[ -z $TORCH_PREFIX ]] && gc_log "no torch in $PY: engine/torch is built against the LibTorch CMake finds by default"
gc_run build-torch "$GC_OUT/logs/build-torch.log" "$BUILD_LIMIT" bash -c \
  "cmake -S '$ROOT/tools/gpu_check' -B '$B2' $(printf '%q ' "${CMAKE_COMMON[@]}" "${TORCH_ARGS[@]}") && cmake --build '$B2' -j $JOBS"
TORCH_DETAIL="torch CMake files"
if ((GC_RC != 0)) && [[ -n $TORCH_PREFIX ]] && ! grep -q 'Torch .* from' "$GC_OUT/logs/build-torch.log"; then
  # The torch's CMake files failed (not our code): retry with its paths.
  MANUAL=$("$PY" -c 'import torch, torch.utils.cpp_extension as e; print(";".join(e.include_paths()) + "|" + e.library_paths()[0] + "|" + str(int(torch._C._GLIBCXX_USE_CXX11_ABI)))')
  gc_log "find_package(Torch) failed (log build-torch.log); retrying with GC_TORCH_MANUAL=$MANUAL"
  mv "$GC_OUT/logs/build-torch.log" "$GC_OUT/logs/build-torch-cmake-files.log"
  rm -rf "$B2"
  gc_run build-torch "$GC_OUT/logs/build-torch.log" "$BUILD_LIMIT" bash -c \
    "cmake -S '$ROOT/tools/gpu_check' -B '$B2' $(printf '%q ' "${CMAKE_COMMON[@]}" -DGC_WITH_TORCH=ON "-DGC_TORCH_MANUAL=$MANUAL") && cmake --build '$B2' -j $JOBS"
  TORCH_DETAIL="torch paths from Python (its CMake files failed: build-torch-cmake-files.log)"
fi
if ((GC_RC == 0)); then
  gc_row build-torch PASS "$GC_SECONDS" "$(grep -m 1 -o 'Torch .* from [^,]*' "$GC_OUT/logs/build-torch.log"); $TORCH_DETAIL"
else
  gc_row build-torch FAIL "$GC_SECONDS" "exit $GC_RC: $(grep -m 1 -E 'error|Error' "$GC_OUT/logs/build-torch.log" | cut -c1-160)"
fi

# --- GPU steps --------------------------------------------------------------
export OMP_WAIT_POLICY=passive
gc_gtest_step parity "$B1/cuda_parity_test" 240
gc_bench_step bench "$B1/rasterizer_cuda_bench" 240
gc_gtest_step torch-op "$B2/torch_cuda_test" 180
if ((GC_HAVE_GPU)); then
  # The rest of the op's tests on this torch (CPU ones included) beside the
  # CUDA ones: CudaMatchesCpu must run, not skip.
  gc_gtest_step torch-op-all "$B2/torch_rasterize_test" 180
fi
gc_gtest_step mapping "$B2/mapper_cuda_test" 180
grep -h '^\[ \(gradcheck\|mapper\|stages\) *\]' "$GC_OUT/logs/torch-op.log" "$GC_OUT/logs/mapping.log" 2>/dev/null >&2

gc_log "total $(($(date +%s) - T_START)) s"
gc_write_summary
if ((${#GC_FAILED[@]})); then exit 1; fi
if ((!GC_HAVE_GPU)) && [[ $GC_MODE == run ]]; then
  gc_log "FAILED: no GPU, so no GPU step ran (use --dry-run for a compile-only check)"
  exit 1
fi
exit 0
