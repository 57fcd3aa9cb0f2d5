#!/usr/bin/env bash
# Compiles engine/torch/ (every .cc, tests included; compile only, no link)
# against the headers of LibTorch 2.x, to prove the code builds with 2.x as
# well as with Debian 12's LibTorch 1.13.
#
#   tools/check_libtorch2.sh [CACHE_DIR]
#
# The headers come from Debian trixie's libtorch-dev 2.6.0 (the .deb is
# downloaded into CACHE_DIR, default build/libtorch2, once, and unpacked there
# with dpkg -x; a pip wheel of torch would do as well, but this machine has
# no PyPI). The system's own torch headers (/usr/include/torch, 1.13) must
# not be used: each object's dependency list is checked, and a probe fails
# unless TORCH_VERSION_MAJOR is 2. Eigen, GLM and GoogleTest come from the
# system (Debian: libeigen3-dev, libglm-dev, libgtest-dev).
# Exit status: 0 when every file compiled, 1 otherwise (naming the files).
set -uo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
CACHE=$(realpath -m "${1:-$ROOT/build/libtorch2}")
URL=${LIBTORCH2_DEB_URL:-http://deb.debian.org/debian/pool/main/p/pytorch/libtorch-dev_2.6.0+dfsg-7_amd64.deb}
DEB="$CACHE/$(basename "$URL")"
CXX=${CXX:-c++}
mkdir -p "$CACHE/obj" || exit 1

if [[ ! -s $DEB ]]; then
  echo "check_libtorch2: downloading $URL" >&2
  if command -v curl >/dev/null; then
    curl -sSfL -o "$DEB.part" "$URL"
  else
    wget -q -O "$DEB.part" "$URL"
  fi || { rm -f "$DEB.part"; echo "check_libtorch2: FAILED: cannot download $URL into $CACHE" >&2; exit 1; }
  mv "$DEB.part" "$DEB"
fi
HEADERS="$CACHE/root"
if [[ ! -f $HEADERS/usr/include/torch/csrc/api/include/torch/version.h ]]; then
  rm -rf "$HEADERS"
  dpkg -x "$DEB" "$HEADERS" || { echo "check_libtorch2: FAILED: dpkg -x $DEB" >&2; exit 1; }
fi
INC=(-I"$ROOT" -I"$HEADERS/usr/include" -I"$HEADERS/usr/include/torch/csrc/api/include" -I/usr/include/eigen3)
FLAGS=(-std=c++17 -O0 -fsyntax-only -D_GLIBCXX_USE_CXX11_ABI=1 -DEIGEN_MAX_ALIGN_BYTES=16 -Wall -Wextra
  -Wno-unused-parameter -Werror=deprecated-declarations)

# The probe: these headers are LibTorch 2.x.
PROBE="$CACHE/obj/probe.cc"
printf '#include <torch/version.h>\nstatic_assert(TORCH_VERSION_MAJOR == 2, "not LibTorch 2");\n' >"$PROBE"
"$CXX" "${FLAGS[@]}" "${INC[@]}" "$PROBE" || { echo "check_libtorch2: FAILED: $HEADERS is not LibTorch 2" >&2; exit 1; }
VERSION=$(awk '/#define TORCH_VERSION_(MAJOR|MINOR|PATCH) /{v = v (v == "" ? "" : ".") $3} END{print v}' \
  "$HEADERS/usr/include/torch/csrc/api/include/torch/version.h")

failed=()
n=0
t0=$(date +%s)
for src in "$ROOT"/engine/torch/*.cc; do
  name=$(basename "$src" .cc)
  log="$CACHE/obj/$name.log"
  n=$((n + 1))
  # -MD -MF: the headers it read, to check none is the system's torch.
  if "$CXX" "${FLAGS[@]}" "${INC[@]}" -MD -MF "$CACHE/obj/$name.d" "$src" >"$log" 2>&1; then
    if grep -qE '(^| )/usr/include/(torch|ATen|c10)/' "$CACHE/obj/$name.d"; then
      echo "check_libtorch2: $name.cc read the system's LibTorch 1.x headers:" >&2
      grep -oE '/usr/include/(torch|ATen|c10)/[^ ]*' "$CACHE/obj/$name.d" | head -n 3 >&2
      failed+=("$name.cc")
    else
      echo "check_libtorch2: ok $name.cc" >&2
    fi
  else
    echo "check_libtorch2: FAILED $name.cc:" >&2
    grep -m 5 'error' "$log" >&2
    failed+=("$name.cc")
  fi
done
echo "check_libtorch2: $n files against LibTorch $VERSION ($HEADERS) in $(($(date +%s) - t0)) s" >&2
if ((${#failed[@]})); then
  echo "check_libtorch2: FAILED: ${failed[*]}" >&2
  exit 1
fi
echo "check_libtorch2: PASSED" >&2
