#!/bin/bash
# fuzz.sh -- the long fuzz run of the file readers (issue #19). The driver
# tests/fuzz/fuzz_readers.c mutates the seed files of tests/fuzz/corpus/READER
# (bit flips, special bytes, inserted and deleted runs and lines, truncation,
# numbers replaced by extreme values) and requires every input to be read
# (then checked, and a valid mesh remeshed without a crash) or refused with
# a message; `make check` runs 1000 iterations
# per reader (ctest -L fuzz), this script ITER per reader (default 200000).
#
#   bench/fuzz.sh [BUILD_DIR] [READER...]
#
# BUILD_DIR (default build-asan) should be a sanitizer build
# (-DPADAPT_SANITIZE=ON): a Release build only finds crashes, not silent
# overreads or leaks. READERs default to medit-mesh medit-sol gmsh.
# Environment: ITER (iterations per reader, default 200000), SEED (default
# 1), CHUNK (iterations per process, default 10000), CRASHDIR (default
# /tmp/fuzz-crashes), FUZZ_WORK (scratch, default /tmp/padapt-fuzz).
# The run is split into processes of CHUNK iterations, chunk k of a reader
# using seed SEED*1000+k, so an abort loses one chunk only. A chunk that
# aborts or breaks the contract leaves its input (fuzz-last.EXT, or
# fuzz-violation-N.EXT) and its log in CRASHDIR/READER-seedS.*, with the
# command that replays it. Exit status 1 if any chunk failed.
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=$(cd "${1:-$here/../build-asan}" && pwd) || exit 2
shift $(($# > 0 ? 1 : 0))
readers=("$@")
[ ${#readers[@]} -eq 0 ] && readers=(medit-mesh medit-sol gmsh)
iter=${ITER:-200000}
seed=${SEED:-1}
chunk=${CHUNK:-10000}
crashdir=${CRASHDIR:-/tmp/fuzz-crashes}
work=${FUZZ_WORK:-/tmp/padapt-fuzz}
exe="$build/bin/fuzz_readers"
[ -x "$exe" ] || { echo "fuzz.sh: $exe not built" >&2; exit 2; }
mkdir -p "$crashdir" "$work"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$here/../tests/lsan.supp:print_suppressions=0}

status=0
for reader in "${readers[@]}"; do
  corpus="$(cd "$here/../tests/fuzz/corpus" && pwd)/$reader"
  runs=0 ok=0 remeshed=0 errs=0 failed=0 t0=$SECONDS
  for ((k = 0; runs < iter; k++)); do
    n=$((iter - runs < chunk ? iter - runs : chunk))
    s=$((seed * 1000 + k))
    dir="$work/$reader.$s"
    rm -rf "$dir" && mkdir -p "$dir"
    (cd "$dir" && "$exe" "$reader" "$corpus" "$n" "$s") > "$dir/log" 2>&1
    rc=$?
    line=$(grep "^fuzz_readers $reader:" "$dir/log")
    if [ $rc -ne 0 ] || [ -z "$line" ]; then
      failed=$((failed + 1)) status=1
      base="$crashdir/$reader-seed$s"
      cp "$dir/log" "$base.log"
      for f in "$dir"/fuzz-last.* "$dir"/fuzz-violation-*; do
        [ -e "$f" ] && cp "$f" "$base.$(basename "$f")"
      done
      echo "$reader: chunk seed $s failed (exit $rc), kept as $base.*;" \
        "replay: (cd DIR && $exe $reader $corpus $n $s)"
      grep -m 3 -E "ERROR|runtime error|violation|leaked" "$dir/log" | sed 's/^/  /'
    else
      set -- $line
      ok=$((ok + $5)) remeshed=$((remeshed + ${9})) errs=$((errs + ${11}))
      rm -rf "$dir"
    fi
    runs=$((runs + n))
  done
  echo "$reader: $runs runs, $ok read ($remeshed remeshed), $errs refused, $failed failed chunks," \
    "$((SECONDS - t0)) s"
done
exit $status
