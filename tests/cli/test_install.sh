#!/usr/bin/env bash
# `cmake --install` gives a usable package: a program builds against the
# installed library through pkg-config and through CMake's find_package, and
# runs; the CLI and its man page are installed; the Python package imports
# from the prefix and uses the installed library.
set -eu
: "${PADAPT:?PADAPT must point to the padapt binary}"
build=$(cd "$(dirname "$PADAPT")/.." && pwd)
prefix=$PWD/prefix
rm -rf "$prefix" consumer
cmake --install "$build" --prefix "$prefix" > install.log
mkdir -p consumer
cat > consumer/main.c <<'C'
#include <padapt.h>
#include <stdio.h>
int main(void) {
  pa_mesh *m = NULL;
  if (pa_mesh_generate_box(2, 3, &m) != PA_SUCCESS) return 1;
  printf("%d\n", (int)pa_mesh_nelem(m));
  pa_mesh_destroy(m);
  return 0;
}
C
cat > consumer/CMakeLists.txt <<'C'
cmake_minimum_required(VERSION 3.25)
project(consumer C)
find_package(padapt REQUIRED)
add_executable(consumer main.c)
target_link_libraries(consumer PRIVATE padapt::padapt)
C
# A sanitizer build's library needs the sanitizer runtime in the consumer.
san=""
if ldd "$PADAPT" | grep -q libasan; then san="-fsanitize=address,undefined"; fi
# pkg-config
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig:$prefix/lib/x86_64-linux-gnu/pkgconfig"
cc $san consumer/main.c -o consumer/pc $(pkg-config --cflags --libs padapt)
out=$(LD_LIBRARY_PATH="$prefix/lib:$prefix/lib/x86_64-linux-gnu" ./consumer/pc)
[ "$out" = 18 ] || { echo "FAIL pkg-config consumer printed '$out'"; exit 1; }
echo "ok   pkg-config consumer"
# CMake package
cmake -S consumer -B consumer/build -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_C_FLAGS="$san" -DCMAKE_EXE_LINKER_FLAGS="$san" > cmake.log
cmake --build consumer/build > build.log
out=$(LD_LIBRARY_PATH="$prefix/lib:$prefix/lib/x86_64-linux-gnu" ./consumer/build/consumer)
[ "$out" = 18 ] || { echo "FAIL CMake consumer printed '$out'"; exit 1; }
echo "ok   CMake consumer"
[ -x "$prefix/bin/padapt" ] || { echo "FAIL padapt not installed"; exit 1; }
echo "ok   CLI installed"
# the installed CLI finds the installed library by itself (RPATH $ORIGIN)
out=$(env -u LD_LIBRARY_PATH "$prefix/bin/padapt" --version | head -1)
case "$out" in "padapt "*) echo "ok   installed CLI runs without LD_LIBRARY_PATH" ;;
  *) echo "FAIL installed CLI: '$out'"; exit 1 ;; esac
ldd "$prefix/bin/padapt" | grep -q "libpadapt.*$prefix" ||
  { echo "FAIL installed CLI does not use the installed library"; exit 1; }
echo "ok   installed CLI uses $prefix's library"
# Python package (not in a sanitizer build: python3 cannot load it there)
if [ -z "$san" ] && [ -x /usr/bin/python3 ]; then
  init=$(find "$prefix" -path '*/padapt/__init__.py' | head -1)
  [ -n "$init" ] || { echo "FAIL Python package not installed"; exit 1; }
  out=$(cd / && env -u PADAPT_LIB PYTHONPATH="$(dirname "$(dirname "$init")")" /usr/bin/python3 -c '
import padapt
m = padapt.Mesh.generate_box(2, 3)
print(padapt.library_path(), m.nelem)')
  case "$out" in
    "$prefix"/*" 18") echo "ok   Python package ($out)" ;;
    *) echo "FAIL Python package printed '$out'"; exit 1 ;;
  esac
fi
[ -s "$prefix/share/man/man1/padapt.1" ] || { echo "FAIL man page not installed"; exit 1; }
echo "ok   man page installed"
