#!/usr/bin/env bash
# test_layers_planted.sh -- scripts/check-layers.sh fails on a bad include
# planted in a copy of the sources: an upward include in src/, an internal
# header or a path outside tools/ in the CLI; and passes on the copy as it
# is.
#
#   bash tests/lint/test_layers_planted.sh SOURCE_DIR
set -u
root=${1:?source directory}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
fresh() {
  rm -rf "$tmp/w"
  mkdir -p "$tmp/w"
  cp -r "$root/src" "$root/tools" "$tmp/w/"
}
fresh
if ! bash "$root/scripts/check-layers.sh" "$tmp/w" > "$tmp/out"; then
  echo "FAIL: the copy as it is does not pass:"; cat "$tmp/out"; fail=1
fi
plant() { # FILE LINE-TO-ADD WHAT
  fresh
  sed -i "1i $2" "$tmp/w/$1"
  if bash "$root/scripts/check-layers.sh" "$tmp/w" > "$tmp/out"; then
    echo "FAIL: not caught: $3 ($1: $2)"; fail=1
  elif ! grep -q "${1#src/}:1:" "$tmp/out"; then
    echo "FAIL: the message does not name $1:"; cat "$tmp/out"; fail=1
  fi
}
plant src/mesh/mesh.c '#include "metric/metric.h"' "mesh including metric"
plant tools/cli_util.c '#include "core/core.h"' "the CLI including an internal header"
plant tools/svg.c '#include "../src/io/io.h"' "the CLI including a path outside tools/"
plant tools/params.c '#include <io/io.h>' "the CLI including an internal header as <...>"
plant tools/cli.h '#include "nosuch.h"' "the CLI including a header not in tools/"
[ $fail -eq 0 ] && echo "test_layers_planted: every planted include caught"
exit $fail
