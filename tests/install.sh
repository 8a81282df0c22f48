#!/usr/bin/env bash
# tests/install.sh - the installed library, as its users build against it:
#   1. make install PREFIX=<a temporary directory>
#   2. tests/install/host.c built with pkg-config (cc $(pkg-config --cflags
#      --libs kifmm)) against the shared library, and against the static
#      one (libkifmm.a and pkg-config --static's libraries);
#   3. tests/install/CMakeLists.txt: find_package(kifmm) with no build
#      type, host.c linked to kifmm::kifmm and host_headers.c (a kernel of
#      its own, header-only) to kifmm::headers, which must compile with -O2;
#   4. make uninstall, which must leave no file behind.
# The shared host runs once more per instruction-set level the CPU has
# (KIFMM_ISA). Each host checks its results against sums written out in it and prints
# "RESULT <passed> <failed>". The last line here is "install: N passed, N
# failed"; the exit status is nonzero if anything failed.
set -u
cd "$(dirname "$0")/.." || exit 1
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
PREFIX="$TMP/prefix"
passed=0
failed=0
CC=${CC:-cc}

# run NAME COMMAND...: a host program; its RESULT line counts
run() {
    local name=$1 out r
    shift
    out=$("$@" 2>&1)
    r=$?
    echo "$out" | sed 's/^/    /'
    if [ $r -eq 0 ] && echo "$out" | grep -q '^RESULT [0-9]* 0$'; then
        passed=$((passed + $(echo "$out" | awk '/^RESULT/{print $2}')))
        echo "  ok   $name"
    else
        failed=$((failed + 1))
        echo "  FAIL $name (exit $r)"
    fi
}
# step NAME COMMAND...: a build step; a failure counts once
step() {
    local name=$1
    shift
    if "$@" > "$TMP/step.log" 2>&1; then
        passed=$((passed + 1))
        echo "  ok   $name"
    else
        failed=$((failed + 1))
        echo "  FAIL $name:"
        tail -20 "$TMP/step.log" | sed 's/^/    /'
    fi
}

echo "== make install PREFIX=$PREFIX"
step "make install" make --no-print-directory -j2 install PREFIX="$PREFIX"
export PKG_CONFIG_PATH="$PREFIX/lib/pkgconfig"

echo "== a C host built with pkg-config"
step "pkg-config --modversion kifmm: $(pkg-config --modversion kifmm 2>&1)" pkg-config --exists kifmm
# shellcheck disable=SC2046
step "cc host.c \$(pkg-config --cflags --libs kifmm)" \
    $CC -std=c99 -O2 tests/install/host.c $(pkg-config --cflags kifmm) -o "$TMP/host_pc" \
    $(pkg-config --libs kifmm) -lm
run "host, shared library" env LD_LIBRARY_PATH="$PREFIX/lib" "$TMP/host_pc"
# every instruction-set level of the library this CPU runs (KIFMM_ISA,
# src/kifmm_dispatch.c): results and stats.build's level
flags=$(grep -m1 '^flags' /proc/cpuinfo 2>/dev/null)
has() { local f; for f in "$@"; do case " $flags " in *" $f "*) ;; *) return 1 ;; esac; done; }
levels=base
has avx2 fma bmi1 bmi2 f16c movbe abm && levels="$levels avx2"
has avx2 fma bmi1 bmi2 f16c movbe abm avx512f avx512bw avx512cd avx512dq avx512vl && levels="$levels avx512"
for lv in $levels; do
    run "host, shared library, KIFMM_ISA=$lv" env LD_LIBRARY_PATH="$PREFIX/lib" KIFMM_ISA=$lv "$TMP/host_pc"
done
# shellcheck disable=SC2046
step "cc host.c libkifmm.a \$(pkg-config --static --libs kifmm)" \
    $CC -std=c99 -O2 tests/install/host.c $(pkg-config --cflags kifmm) -o "$TMP/host_static" \
    "$PREFIX/lib/libkifmm.a" $(pkg-config --static --libs-only-other --libs-only-l kifmm | sed 's/-lkifmm//')
run "host, static library" "$TMP/host_static"
run "host, static library, KIFMM_ISA=base" env KIFMM_ISA=base "$TMP/host_static"

echo "== CMake hosts: find_package(kifmm), no build type"
step "cmake configure" cmake -S tests/install -B "$TMP/cmake" -DCMAKE_PREFIX_PATH="$PREFIX"
step "cmake build" cmake --build "$TMP/cmake" --verbose
cp "$TMP/step.log" "$TMP/build.log"
step "kifmm::headers compiles with -O2 when no build type is set" \
    grep -q -- '-O2 .*host_headers.c' "$TMP/build.log"
run "CMake host, kifmm::kifmm" "$TMP/cmake/host"
run "CMake host, kifmm::headers (a kernel of its own)" "$TMP/cmake/host_headers"

echo "== make uninstall"
step "make uninstall" make --no-print-directory uninstall PREFIX="$PREFIX"
left=$(find "$PREFIX" -type f -o -type l 2>/dev/null | wc -l)
step "no file left under the prefix ($left)" test "$left" -eq 0

echo "install: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
