#!/usr/bin/env bash
# `padapt adapt` on 2D meshes: -hsiz and -met runs produce a valid mesh, its
# metric (OUT.sol) and a JSON report with time_s / peak_rss_bytes / outcome;
# -in is accepted; -field files are interpolated and written; bad options
# fail with a message and no output; the output is the same on repeated runs.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
json_num() { # json_num FILE KEY -> the number after "KEY":
  sed -n "s/.*\"$2\": *\\([-0-9.eE+]*\\).*/\\1/p" "$1" | head -1
}

"$PADAPT" generate box2d 8 sq.mesh > /dev/null || fail "generate"

# constant size
rm -f out.mesh out.sol r.json
"$PADAPT" adapt sq.mesh -hsiz 0.05 -out out.mesh -json r.json > log1.txt 2>&1 \
  || { cat log1.txt; fail "adapt -hsiz exit status"; }
[ -s out.mesh ] || fail "adapt -hsiz: no out.mesh"
[ -s out.sol ] || fail "adapt -hsiz: no out.sol next to the mesh"
grep -q "OUTPUT" log1.txt || fail "adapt: no after-statistics printed"
grep -q "time" log1.txt || fail "adapt: no time printed"
for k in time_s peak_rss_bytes outcome nsplit edge_in_range quality_worst; do
  grep -q "\"$k\"" r.json || fail "report lacks $k"
done
grep -q '"outcome": "success"' r.json || fail "adapt -hsiz: outcome not success"
grep -q '"valid": true' r.json || fail "adapt -hsiz: output not valid"
inr=$(json_num r.json edge_in_range)
awk -v v="$inr" 'BEGIN { exit !(v >= 0.98) }' || fail "edges in range $inr < 0.98"
"$PADAPT" stats out.mesh -met out.sol > /dev/null || fail "stats on the output"

# Mmg's -in spelling, same result bytes (determinism)
"$PADAPT" adapt -in sq.mesh -hsiz 0.05 -out out2.mesh > /dev/null 2>&1 || fail "adapt -in"
cmp -s out.mesh out2.mesh || fail "two runs gave different meshes"

# a metric file, and a user field interpolated
"$PADAPT" metric shell:0.3 sq.mesh m.sol > /dev/null || fail "metric"
"$PADAPT" metric uniform:0.5 sq.mesh f.sol > /dev/null || fail "metric (field)"
rm -f a.mesh a.sol a.fields.sol
"$PADAPT" adapt sq.mesh -met m.sol -out a.mesh -field f.sol -hgrad 1.5 \
  -json a.json > log2.txt 2>&1 || { cat log2.txt; fail "adapt -met -field"; }
[ -s a.sol ] || fail "adapt -met: no a.sol"
[ -s a.fields.sol ] || fail "adapt -field: no a.fields.sol"
"$PADAPT" stats a.mesh -met a.fields.sol > /dev/null 2>&1 || fail "field file does not match the output mesh"
grep -q '"valid": true' a.json || fail "adapt -met: output not valid"

# target missed is a warning, exit 0, outcome in the report
"$PADAPT" adapt sq.mesh -hsiz 0.02 -noinsert -out b.mesh -json b.json > /dev/null 2> err.txt \
  || fail "-noinsert: exit status"
grep -q '"outcome": "target missed"' b.json || fail "-noinsert: outcome"
grep -qi "target missed" err.txt || fail "-noinsert: no warning"

# bad options: message, non-zero exit, no output
for args in "-hsiz -1" "-hsiz abc" "-hmin 0.2 -hmax 0.1 -hsiz 0.1" "-bogus" \
            "-hsiz 0.1 -met m.sol" "" "-ar 200 -hsiz 0.1"; do
  rm -f bad.mesh
  # shellcheck disable=SC2086
  "$PADAPT" adapt sq.mesh $args -out bad.mesh > /dev/null 2> err.txt
  rc=$?
  [ $rc -ne 0 ] || fail "adapt $args: exit status 0"
  [ $rc -lt 128 ] || fail "adapt $args: crashed ($rc)"
  [ -s err.txt ] || fail "adapt $args: no message"
  [ -e bad.mesh ] && fail "adapt $args: wrote an output"
done
rm -f sq.o.mesh
"$PADAPT" adapt sq.mesh -hsiz 0.1 > /dev/null 2> err.txt && [ -s sq.o.mesh ] ||
  fail "no -out: no default output sq.o.mesh (Mmg's IN.o.mesh)"
"$PADAPT" adapt missing.mesh -hsiz 0.1 -out x.mesh > /dev/null 2> err.txt && fail "missing input accepted"
grep -q "missing.mesh" err.txt || fail "missing input: message does not name the file"

[ $fails -eq 0 ] && echo "test_adapt2d: all passed"
exit $((fails > 0))
