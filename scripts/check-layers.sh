#!/usr/bin/env bash
# check-layers.sh -- the library's components include one another one way
# only (docs/ARCHITECTURE.md): each may include the headers of the
# components listed for it below, all on lower layers, and its own; the CLI
# (tools/) includes the public header padapt.h and its own headers only.
# Prints every #include that crosses a layer the wrong way and exits 1 if
# there is one. The layers, from the bottom:
#   0 core   1 mesh, partition   2 metric   3 io, remesh
#   4 dmesh, remesh2d, remesh3d   5 remesher   6 adapt
#
#   bash scripts/check-layers.sh [SOURCE_DIR]
set -u
root=${1:-$(cd "$(dirname "$0")/.." && pwd)}
src=$root/src
declare -A allowed=(
  [core]=""
  [mesh]="core"
  # geom/ is the only code that calls Gmsh's library (gmshc.h, checked
  # below), as partition/ is the only one that calls PT-Scotch.
  [geom]="core mesh"
  [metric]="core mesh geom"
  [io]="core mesh metric"
  [partition]="core"
  # remesh/ holds what the 2D and 3D remeshers share (the private header
  # remesh/remesh.h, the pass schedule, bisection, the field transfer); they
  # include it, never each other. The plug-in interface and driver
  # (remesher/) calls them through the entries remesh/remesh.h declares.
  [remesh]="core mesh metric geom"
  [remesh2d]="core mesh metric remesh"
  [remesh3d]="core mesh metric remesh geom"
  [remesher]="core mesh metric geom remesh"
  [dmesh]="core mesh metric io partition"
  [adapt]="core mesh metric io partition remesh dmesh geom"
)
bad=0
for dir in "$src"/*/; do
  comp=$(basename "$dir")
  if [ -z "${allowed[$comp]+set}" ]; then
    echo "check-layers: src/$comp is not a known component (add it here)"
    bad=1
    continue
  fi
  while IFS=: read -r file line text; do
    inc=$(sed -E 's/.*#include "([a-z0-9_]+)\/.*/\1/' <<< "$text")
    [ "$inc" = "$comp" ] && continue
    case " ${allowed[$comp]} " in
      *" $inc "*) ;;
      *) echo "check-layers: ${file#"$src"/}:$line: $comp includes $inc: $text"; bad=1 ;;
    esac
  done < <(grep -Hn '^#include "[a-z0-9_]*/' "$dir"*.[ch] 2>/dev/null)
done
# tools/: "padapt.h" or a header of tools/ itself, nothing of src/
while IFS=: read -r file line text; do
  inc=$(sed -E 's/.*#include "([^"]+)".*/\1/' <<< "$text")
  [ "$inc" = padapt.h ] && continue
  case $inc in
    */*) ;;
    *) [ -f "$root/tools/$inc" ] && continue ;;
  esac
  echo "check-layers: tools/${file#"$root"/tools/}:$line: the CLI includes $inc" \
       "(only padapt.h and tools/*.h): $text"
  bad=1
done < <(grep -Hn '^[[:space:]]*#[[:space:]]*include[[:space:]]*"' "$root"/tools/*.[ch] 2>/dev/null)
# nor through the system include path
while IFS=: read -r file line text; do
  inc=$(sed -E 's/.*#include *<([^>]+)>.*/\1/' <<< "$text")
  [ -d "$src/${inc%%/*}" ] || continue
  echo "check-layers: tools/${file#"$root"/tools/}:$line: the CLI includes $inc" \
       "(only padapt.h and tools/*.h): $text"
  bad=1
done < <(grep -Hn '^[[:space:]]*#[[:space:]]*include[[:space:]]*<[a-z0-9_]*/' "$root"/tools/*.[ch] 2>/dev/null)
# Gmsh's C API: src/geom/ only
while IFS=: read -r file line text; do
  case $file in "$src"/geom/*) continue ;; esac
  echo "check-layers: ${file#"$root"/}:$line: only src/geom/ calls Gmsh: $text"
  bad=1
done < <(grep -rHn '^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]gmshc\?\.h' "$src" "$root"/tools 2>/dev/null)
[ $bad -eq 0 ] && echo "check-layers: every include goes down the layers"
exit $bad
