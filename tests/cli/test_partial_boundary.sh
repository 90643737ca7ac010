#!/usr/bin/env bash
# Meshes that list only part of their boundary entities are completed as Mmg
# does: the missing ones added with reference 0, the listed ones keeping
# theirs, a boundary entity listed twice kept once, a note at -v 1; then
# adapted like any mesh, on 1 to 4 processes. The files: tests/data/
# partial2d.mesh (a plate whose file lists the edges of its hole only, the
# shape of Mmg's naca-multiSols.mesh, whose far field is not listed) and a
# cube that lists the triangles of its side x = 0 only.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}" "${MPIEXEC:?}"
data="${PADAPT_TESTDATA:?}"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
rm -f ./*.mesh ./*.sol err.txt

# The references of the boundary entities of a Medit file (keyword KW), as
# "REF:COUNT" lines, and a check on the coordinates of the vertices of each.
refs() { # FILE KW
  awk -v kw="$2" '$1 == kw {f = 1; n = -1; next}
    f && n < 0 && NF == 1 {n = $1; next}
    f && n > 0 {c[$NF]++; if (--n == 0) f = 0}
    END {for (r in c) print r ":" c[r]}' "$1" | sort
}
# every vertex of the KW entities of reference REF satisfies the awk
# condition COND on x, y, z (prints the first that does not)
on() { # FILE KW REF COND
  awk -v kw="$2" -v ref="$3" '
    $1 == "Vertices" {v = 1; n = -1; next}
    v && n < 0 && NF == 1 {n = $1; i = 0; next}
    v && n > 0 {x[++i] = $1; y[i] = $2; z[i] = (NF > 3 ? $3 : 0); if (i == n) v = 0; next}
    $1 == kw {f = 1; m = -1; next}
    f && m < 0 && NF == 1 {m = $1; next}
    f && m > 0 {if ($NF == ref) for (k = 1; k < NF; k++) {X = x[$k]; Y = y[$k]; Z = z[$k];
                  if (!('"$4"')) {print $k; exit}}
                if (--m == 0) f = 0}' "$1"
}

# 2D: the hole's edges (51) listed, the outer ones not.
"$PADAPT" -v 1 stats "$data/partial2d.mesh" > /dev/null 2> err.txt \
  && grep -q "lists 27 of its 59 boundary edges: added the 32 missing (reference 0)" err.txt \
  && ok "2D: the missing boundary edges added, with a note" \
  || bad "2D stats: $(head -c 300 err.txt)"
outer='X < -1.999 || X > 2.999 || Y < -1.999 || Y > 1.999'
for np in 0 1 2 3 4; do
  if [ $np -eq 0 ]; then
    "$PADAPT" adapt "$data/partial2d.mesh" -hsiz 0.15 -out a2.mesh > /dev/null 2> err.txt
  else
    "$MPIEXEC" -n $np "$PADAPT" adapt "$data/partial2d.mesh" -hsiz 0.15 -out a2.mesh \
      > /dev/null 2> err.txt
  fi
  rc=$?
  r=$(refs a2.mesh Edges | tr '\n' ' ')
  if [ $rc -ne 0 ]; then bad "2D np $np: exit status $rc: $(head -c 300 err.txt)"
  elif ! printf '%s' "$r" | grep -q "^0:[0-9]* 51:[0-9]* $"; then bad "2D np $np: boundary references $r"
  elif [ -n "$(on a2.mesh Edges 0 "$outer")" ]; then bad "2D np $np: an added edge off the outer boundary"
  elif [ -n "$(on a2.mesh Edges 51 "!($outer)")" ]; then bad "2D np $np: a hole edge on the outer boundary"
  else ok "2D np $np: adapted; hole edges keep 51, outer edges 0 ($r)"; fi
done

# An edge listed twice (as naca-multiSols.mesh lists six): kept once.
awk '$1 == "Edges" {print; getline; print $1 + 1; getline; print; dup = $0; print dup; next} {print}' \
  "$data/partial2d.mesh" > dup2.mesh
"$PADAPT" -v 1 adapt dup2.mesh -hsiz 0.3 -out d2.mesh > /dev/null 2> err.txt \
  && grep -q "1 boundary edges listed twice: kept the first listing" err.txt \
  && ok "2D: an edge listed twice kept once" || bad "2D duplicate edge: $(head -c 300 err.txt)"

# 3D: only the side x = 0 (reference 1) listed.
"$PADAPT" generate box3d 3 cube.mesh > /dev/null
awk '$1 == "Triangles" {print; getline; t = $1; n = 0
       for (i = 0; i < t; i++) {getline; if ($NF == 1) keep[++n] = $0}
       print n; for (i = 1; i <= n; i++) print keep[i]; next} {print}' cube.mesh > side.mesh
for np in 0 2; do
  if [ $np -eq 0 ]; then
    "$PADAPT" -v 1 adapt side.mesh -hsiz 0.2 -out a3.mesh > /dev/null 2> err.txt
  else
    "$MPIEXEC" -n $np "$PADAPT" -v 1 adapt side.mesh -hsiz 0.2 -out a3.mesh > /dev/null 2> err.txt
  fi
  rc=$?
  r=$(refs a3.mesh Triangles | tr '\n' ' ')
  if [ $rc -ne 0 ]; then bad "3D np $np: exit status $rc: $(head -c 300 err.txt)"
  elif ! grep -q "lists 18 of its 108 boundary triangles" err.txt; then bad "3D np $np: no note: $(head -c 300 err.txt)"
  elif ! printf '%s' "$r" | grep -q "^0:[0-9]* 1:[0-9]* $"; then bad "3D np $np: boundary references $r"
  elif [ -n "$(on a3.mesh Triangles 1 'X < 1e-12')" ]; then bad "3D np $np: a listed triangle off x = 0"
  elif [ -n "$(on a3.mesh Triangles 0 'X > 1e-12 || (Y < 1e-12 || Y > 1 - 1e-12 || Z < 1e-12 || Z > 1 - 1e-12)')" ]; then
    bad "3D np $np: an added triangle on x = 0"
  else ok "3D np $np: adapted; side x = 0 keeps 1, the others 0 ($r)"; fi
  rm -f a3.mesh
done
echo "$fails failed"
[ $fails -eq 0 ]
