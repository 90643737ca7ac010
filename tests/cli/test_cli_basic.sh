#!/usr/bin/env bash
# The basic commands of the CLI: generate, metric, stats (text and JSON),
# convert through every format and back, usage errors.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
fails=0
ok()   { echo "ok   $1"; }
bad()  { echo "FAIL $1"; fails=$((fails + 1)); }
expect_fail() { # description, command...
  local d=$1; shift
  if "$@" > /dev/null 2> err.txt; then bad "$d (exit 0)";
  elif [ ! -s err.txt ]; then bad "$d (no message)"; else ok "$d"; fi
}
json() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }

"$PADAPT" --help | grep -q "generate" && ok "help" || bad "help"
expect_fail "unknown command" "$PADAPT" frobnicate
expect_fail "generate bad shape" "$PADAPT" generate box4d 3 x.mesh
expect_fail "generate bad N" "$PADAPT" generate box2d -3 x.mesh
expect_fail "stats missing file" "$PADAPT" stats nowhere.mesh
expect_fail "stats unknown option" "$PADAPT" stats x.mesh -frob
expect_fail "metric unknown field" "$PADAPT" metric nosuchfield x.mesh m.sol

for d in 2 3; do
  n=4; [ $d = 3 ] && n=3
  "$PADAPT" generate box${d}d $n sq.mesh || bad "generate box${d}d"
  "$PADAPT" stats sq.mesh -json s.json > s.txt || bad "stats box${d}d"
  ne=$(json s.json elements)
  want=$((2 * n * n)); [ $d = 3 ] && want=$((6 * n * n * n))
  [ "$ne" = "$want" ] && ok "box${d}d element count $ne" || bad "box${d}d elements $ne != $want"
  [ "$(json s.json valid)" = "True" ] || [ "$(json s.json valid)" = "1" ] && ok "box${d}d valid" || bad "box${d}d valid"
  grep -qi "quality" s.txt && ok "text report" || bad "text report"
  for f in uniform:0.2 layer shell iso-shell; do
    "$PADAPT" metric $f sq.mesh m.sol && "$PADAPT" stats sq.mesh -met m.sol -json m.json > /dev/null \
      && ok "metric $f ${d}D" || bad "metric $f ${d}D"
  done
  # uniform:0.25 on the 4x4 square: every axis edge has length exactly 1
  if [ $d = 2 ]; then
    "$PADAPT" metric uniform:0.25 sq.mesh u.sol && "$PADAPT" stats sq.mesh -met u.sol -json u.json > /dev/null
    /usr/bin/python3 -c "import json,sys; sys.exit(0 if json.load(open('u.json'))['edge_min'] == 1.0 else 1)" && ok "uniform metric lengths" || bad "uniform edge_min $(json u.json edge_min)"
  fi
  for ext in mesh meshb msh vtu; do
    "$PADAPT" convert sq.mesh c.$ext -met m.sol && [ -s c.$ext ] && ok "convert to .$ext" || bad "convert to .$ext ${d}D"
  done
  "$PADAPT" convert sq.mesh cb.msh -binary && ok "convert to binary .msh" || bad "binary msh ${d}D"
  for v in 1 2 3 4; do
    "$PADAPT" convert sq.mesh v$v.meshb -meshb-version $v || bad "meshb version $v"
  done
  for ext in meshb msh; do
    "$PADAPT" convert c.$ext back.mesh && "$PADAPT" stats back.mesh -json b.json > /dev/null \
      && [ "$(json b.json elements)" = "$want" ] && [ "$(json b.json volume)" = "$(json s.json volume)" ] \
      && ok "round trip .$ext ${d}D" || bad "round trip .$ext ${d}D"
  done
  "$PADAPT" convert cb.msh back2.mesh && cmp -s back.mesh back2.mesh && ok "binary msh = ascii msh" || bad "binary msh differs ${d}D"
done
# A failed write leaves no file behind.
expect_fail "write into missing directory" "$PADAPT" convert sq.mesh no/such/dir/x.mesh
ls no 2> /dev/null && bad "directory created"
[ $fails -eq 0 ] && echo "all passed" || echo "$fails failed"
[ $fails -eq 0 ]
