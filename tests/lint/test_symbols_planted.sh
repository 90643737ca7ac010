#!/usr/bin/env bash
# test_symbols_planted.sh -- scripts/check-symbols.sh fails on a library
# that exports a symbol without the pa_ prefix (a global table, as the 3D
# remesher's once were, or a function), shared or static, and names it;
# and passes on one whose exports are all pa_ or pa__.
#
#   bash tests/lint/test_symbols_planted.sh SOURCE_DIR C_COMPILER
set -u
root=${1:?source directory}
cc=${2:?C compiler}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
good='const int pa__table[2] = {1, 2};
static int helper(int i) { return pa__table[i]; }
int pa_public(int i) { return helper(i); }'
build() { # NAME SOURCE: lib NAME.so and NAME.a
  printf '%s\n' "$2" > "$tmp/$1.c"
  "$cc" -fPIC -c -o "$tmp/$1.o" "$tmp/$1.c" &&
    "$cc" -shared -o "$tmp/$1.so" "$tmp/$1.o" &&
    ar rcs "$tmp/$1.a" "$tmp/$1.o"
}
expect() { # NAME pass|fail [SYMBOL]
  for lib in "$tmp/$1.so" "$tmp/$1.a"; do
    if bash "$root/scripts/check-symbols.sh" "$lib" > "$tmp/out"; then
      [ "$2" = pass ] || { echo "FAIL: not caught: $3 in $lib"; fail=1; }
    else
      if [ "$2" = pass ]; then
        echo "FAIL: $lib does not pass:"; cat "$tmp/out"; fail=1
      elif ! grep -q "exports $3 " "$tmp/out"; then
        echo "FAIL: the message does not name $3:"; cat "$tmp/out"; fail=1
      fi
    fi
  done
}
build good "$good" || { echo "FAIL: cannot build with $cc"; exit 1; }
expect good pass
build table "$good
const int rm3d_edge[2][2] = {{0, 1}, {1, 2}};"
expect table fail rm3d_edge
build func "$good
int helper_global(int i) { return i + pa__table[0]; }"
expect func fail helper_global
build var "$good
double counter = 1.0;"
expect var fail counter
[ $fail -eq 0 ] && echo "test_symbols_planted: every planted symbol caught"
exit $fail
