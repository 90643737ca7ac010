#!/usr/bin/env bash
# What a Mmg user expects of the command line, and the live progress line:
# --version (and the version in the JSON report), -v -1 (errors only), the
# default output IN.o.EXT with its IN.o.sol, IN.sol picked up as the metric
# when it lies beside IN, -optim, -m MB as -mem, -hgrad -1, the exit status, and
# progress lines on stderr (per pass, per parallel iteration), silenced by
# -v -1, and -hmax bounding -hsiz.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
MPIEXEC=${MPIEXEC:-mpiexec}
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
json() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }

# --version: the header's numbers, as the library reports them
want=$(awk '/#define PADAPT_VERSION_(MAJOR|MINOR|PATCH) /{v = v (v ? "." : "") $3} END {print v}' \
  "$PADAPT_SRC/include/padapt.h")
"$PADAPT" --version > v.txt
head -1 v.txt | grep -qx "padapt $want (header $want)" && ok "--version $want" ||
  bad "--version says '$(head -1 v.txt)', header $want"

"$PADAPT" generate box2d 8 sq.mesh > /dev/null || exit 1
"$PADAPT" metric uniform:0.05 sq.mesh sq.sol || exit 1
rm -f sq.o.mesh sq.o.sol

# IN.sol beside IN is the metric; the output is IN.o.mesh with IN.o.sol
"$PADAPT" adapt sq.mesh -json r.json > log.txt 2> err.txt; rc=$?
[ $rc -eq 0 ] && [ -s sq.o.mesh ] && [ -s sq.o.sol ] && ok "default output sq.o.mesh + sq.o.sol" ||
  bad "default output (exit $rc): $(ls)"
grep -q "metric sq.sol (found beside sq.mesh)" log.txt && ok "IN.sol found and said" ||
  bad "IN.sol not reported: $(head -2 log.txt)"
# the found metric was used: uniform 0.05 on the unit square, not the input sizes
ne=$(json r.json elements)
[ "$ne" -gt 500 ] && ok "adapted to sq.sol ($ne elements)" || bad "sq.sol not used ($ne elements)"
[ "$(json r.json padapt_version)" = "$want" ] && ok "version in the JSON report" ||
  bad "JSON version $(json r.json padapt_version)"
# an explicit -hsiz wins over IN.sol
"$PADAPT" adapt sq.mesh -hsiz 0.2 -out h.mesh -json h.json > log2.txt 2>&1
! grep -q "found beside" log2.txt && [ "$(json h.json elements)" -lt 200 ] &&
  ok "-hsiz wins over IN.sol" || bad "-hsiz with IN.sol beside: $(json h.json elements) elements"

# -v -1: nothing on stdout, the same mesh
"$PADAPT" -v -1 adapt sq.mesh -out q.mesh > out.txt 2> err.txt; rc=$?
[ $rc -eq 0 ] && [ ! -s out.txt ] && cmp -s q.mesh sq.o.mesh && ok "-v -1 silent, same mesh" ||
  bad "-v -1: exit $rc, $(wc -c < out.txt) bytes on stdout"
"$PADAPT" adapt sq.mesh -v -1 -out q2.mesh > out.txt 2>&1
[ ! -s out.txt ] && ok "adapt -v -1 silent" || bad "adapt -v -1 printed $(head -1 out.txt)"
"$PADAPT" -v 11 stats sq.mesh > /dev/null 2> err.txt && bad "-v 11 accepted" ||
  { grep -q "\[-1, 10\]" err.txt && ok "-v 11 refused" || bad "-v 11 message: $(cat err.txt)"; }

# -hgrad -1 disables the gradation (Mmg's convention)
"$PADAPT" adapt sq.mesh -met sq.sol -hgrad -1 -out g.mesh > g.txt 2>&1 && ok "-hgrad -1 accepted" ||
  bad "-hgrad -1: $(tail -1 g.txt)"

# -optim: the input's own sizes, quality improved: the element count stays
# within 20 %, the worst quality does not fall; sequential and on 2 ranks
cp "$PADAPT_SRC/tests/data/plate2d.mesh" o.mesh
"$PADAPT" stats o.mesh -json o0.json > /dev/null
for np in 1 2; do
  if [ $np = 1 ]; then "$PADAPT" adapt o.mesh -optim -out oo.mesh -json o.json > o.txt 2>&1
  else "$MPIEXEC" -n 2 "$PADAPT" adapt o.mesh -optim -out oo.mesh -json o.json > o.txt 2>&1; fi
  rc=$?
  /usr/bin/python3 - o0.json o.json <<'PY' && [ $rc -eq 0 ] && ok "-optim np=$np" || bad "-optim np=$np (exit $rc)"
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
ok = abs(b["elements"] / a["elements"] - 1) < 0.2 and b["quality_worst"] >= a["quality_worst"] - 1e-9
print("  elements %d -> %d, worst quality %.3f -> %.3f" % (a["elements"], b["elements"], a["quality_worst"], b["quality_worst"]))
sys.exit(0 if ok else 1)
PY
done
"$PADAPT" adapt o.mesh -optim -hsiz 0.1 -out x.mesh > /dev/null 2> err.txt && bad "-optim with -hsiz accepted" ||
  { grep -q "optim" err.txt && ok "-optim with -hsiz refused" || bad "-optim -hsiz message: $(cat err.txt)"; }

# -m MB is -mem: a bound too small for the metric is refused, nothing
# written (1 MB is reached already by reading the mesh, or else by the
# estimate)
rm -f m.mesh
"$PADAPT" adapt sq.mesh -hsiz 0.001 -m 1 -out m.mesh > m.txt 2>&1; rc=$?
[ $rc -eq 1 ] && [ ! -e m.mesh ] &&
  grep -q "more than -mem 1\|memory bound of 1.0 MB is reached" m.txt && ok "-m 1 refuses" ||
  bad "-m 1: exit $rc, $(grep -m1 padapt: m.txt)"

# exit status 1 and nothing written on a failure
"$PADAPT" adapt nowhere.mesh -hsiz 0.1 > /dev/null 2>&1; [ $? -eq 1 ] && ok "exit 1 on error" || bad "exit status on error"

# progress: lines on stderr (not a terminal here), per pass and per iteration
PADAPT_PROGRESS_AFTER=0 "$PADAPT" adapt sq.mesh -hsiz 0.01 -out p.mesh > /dev/null 2> err.txt
grep -Eq "^padapt: pass 1: [0-9.]+ (k |M )?elements \(metric: ~[0-9.]+( k| M)?\), [0-9.]+ % of edges in range" err.txt &&
  ok "progress per pass" ||
  bad "no progress line: $(head -2 err.txt)"
PADAPT_PROGRESS_AFTER=0 "$PADAPT" adapt sq.mesh -hsiz 0.01 -out p.mesh -v -1 > /dev/null 2> err.txt
[ ! -s err.txt ] && ok "-v -1 silences the progress" || bad "-v -1 progress: $(head -1 err.txt)"
PADAPT_PROGRESS_AFTER=0 "$MPIEXEC" -n 2 "$PADAPT" adapt sq.mesh -hsiz 0.01 -out p2.mesh > /dev/null 2> err.txt
n=$(grep -c "^padapt: iteration [0-9]*: .* done" err.txt)
last=$(grep "^padapt: iteration" err.txt | tail -1)
[ "$n" -ge 2 ] && echo "$last" | grep -q "100.0 % done" && ok "progress per iteration ($n lines)" ||
  bad "parallel progress: $n lines, last '$last'"
# a run shorter than the quiet time prints no progress
PADAPT_PROGRESS_AFTER=1000 "$PADAPT" adapt sq.mesh -hsiz 0.01 -out s.mesh > /dev/null 2> err.txt
! grep -q "^padapt: pass" err.txt && ok "short run quiet" || bad "progress in a short run"

# -hsiz with -hmax below it: -hmax bounds the sizes in 3D as in 2D (the 3D
# remesher once took -hsiz over the prepared metric)
"$PADAPT" generate box3d 4 cube.mesh > /dev/null || exit 1
for dim in 2 3; do
  in=$([ $dim = 2 ] && echo sq.mesh || echo cube.mesh)
  "$PADAPT" adapt "$in" -hsiz 0.2 -out a$dim.mesh -nosol -v -1 -json a$dim.json > /dev/null 2>&1
  "$PADAPT" adapt "$in" -hsiz 0.2 -hmax 0.1 -out b$dim.mesh -nosol -json b$dim.json > b$dim.log 2>&1
  na=$(json a$dim.json elements); nb=$(json b$dim.json elements)
  [ "$nb" -gt $((3 * na)) ] && grep -q "limited by -hmax" b$dim.log &&
    ok "${dim}D -hsiz 0.2 -hmax 0.1: $nb elements against $na" ||
    bad "${dim}D -hmax ignored with -hsiz: $nb elements against $na"
done

[ $fails -eq 0 ] && echo "all checks passed" || { echo "$fails check(s) failed"; exit 1; }
