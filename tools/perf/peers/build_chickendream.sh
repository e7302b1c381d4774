#!/bin/sh
# Builds tools/perf/peers/chickendream_driver.cpp against a chickendream
# checkout's grain core (src/fgrn, src/fstb), with the flags of chickendream's
# own build/unix/configure.ac + Makefile.am on x86-64 with g++:
#   -std=c++14 -O3 -g3 -DNDEBUG -mfpmath=sse -msse2 -mcx16
#   src/fgrn/GenGrain_avx.cpp with -mavx, src/fstb/ToolsAvx2.cpp with -mavx2
# Usage: build_chickendream.sh CHICKENDREAM_CHECKOUT [OUT_DIR]
# Output: OUT_DIR/chickendream_driver (OUT_DIR defaults to CHECKOUT/driver-build).
# Nothing is written into the filmgrain repository.
set -eu
src_root=$(cd "$1" && pwd)/src
out=${2:-$1/driver-build}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
CXX=${CXX:-g++}
common="-std=c++14 -O3 -g3 -DNDEBUG -mfpmath=sse -msse2 -mcx16 -Wno-ignored-attributes -I$src_root"
objs=""
compile() { # file extra-flags
	o="$out/$(basename "$1" .cpp).o"
	$CXX $common $2 -c "$1" -o "$o"
	objs="$objs $o"
}
for f in fgrn/CellCache.cpp fgrn/GenGrain.cpp fgrn/GrainDensity.cpp fgrn/VisionFilter.cpp \
         fstb/CpuId.cpp fstb/fnc_fstb.cpp fstb/ToolsSimd.cpp; do
	compile "$src_root/$f" ""
done
compile "$src_root/fstb/ToolsSse2.cpp" "-msse2"
compile "$src_root/fgrn/GenGrain_avx.cpp" "-mavx"
compile "$src_root/fstb/ToolsAvx2.cpp" "-mavx2"
compile "$here/chickendream_driver.cpp" ""
$CXX -o "$out/chickendream_driver" $objs -pthread -latomic
echo "$out/chickendream_driver"
