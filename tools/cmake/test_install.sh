#!/usr/bin/env bash
# Installs the build into a temporary prefix, then configures, builds and runs
# tools/example_consumer against it with find_package(dypho).
# Usage: test_install.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src="$1"
build="$2"
prefix="$build/test_install/prefix"
consumer="$build/test_install/consumer"
rm -rf "$build/test_install"
cmake --install "$build" --prefix "$prefix" > "$build/test_install.log"
cmake -S "$src/tools/example_consumer" -B "$consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -Ddypho_DIR="$prefix/lib/cmake/dypho" >> "$build/test_install.log"
cmake --build "$consumer" >> "$build/test_install.log"
"$consumer/dypho_consumer" "$build/test_install/consumer_out"
