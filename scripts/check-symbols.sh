#!/usr/bin/env bash
# check-symbols.sh -- every symbol the library exports is padapt's
# (docs/ARCHITECTURE.md, "Names"): pa_ (public) or pa__ (internal). A table
# or helper local to a component that forgets its static or its prefix
# would otherwise enter every user's name space. Prints each defined
# symbol with another name and exits 1 if there is one.
#
#   bash scripts/check-symbols.sh LIBRARY   (libpadapt.so, or libpadapt.a)
#
# Not counted: the linker's own symbols of a shared object (_init, _fini,
# _edata, _end, __bss_start), and AddressSanitizer's ODR indicators
# (__odr_asan.NAME), whose NAME is checked instead.
set -u
lib=${1:?library}
[ -f "$lib" ] || { echo "check-symbols: no file $lib"; exit 2; }
case $lib in
  *.a) list=$(nm -g --defined-only "$lib") ;; # the members' global symbols
  *) list=$(nm -D --defined-only "$lib") ;;   # the dynamic symbol table
esac || { echo "check-symbols: nm failed on $lib"; exit 2; }
bad=0 n=0
while read -r _ type name; do
  [ -n "${name:-}" ] || continue # archive member headers, blank lines
  case $type in A) continue ;; esac # version nodes
  case $name in
    _init | _fini | _edata | _end | __bss_start) continue ;;
  esac
  name=${name#__odr_asan.}
  name=${name%%@*} # a symbol version
  n=$((n + 1))
  case $name in
    pa_*) ;;
    *) echo "check-symbols: $lib exports $name (type $type): not pa_ or pa__"; bad=1 ;;
  esac
done <<< "$list"
if [ $n -eq 0 ]; then
  echo "check-symbols: $lib exports no symbol (not the library?)"
  exit 2
fi
[ $bad -eq 0 ] && echo "check-symbols: all $n exported symbols start with pa_"
exit $bad
