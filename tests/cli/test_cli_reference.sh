#!/usr/bin/env bash
# The command reference mirrors -h: every option token (-name, --name) in
# the -h text of a command appears in that command's section of
# docs/guide/cli.md ("## `padapt CMD`"; the options of `padapt -h` itself
# anywhere in the page), and every option in the first column of a table
# of such a section is one that command's -h knows ("## Global options":
# padapt -h). The committed man page docs/padapt.1 must be exactly what
# scripts/gen-man.sh makes of the -h texts, so neither can go stale.
set -u
: "${PADAPT:?PADAPT must point to the padapt binary}"
: "${PADAPT_SRC:?PADAPT_SRC must point to the source tree}"
build=$(cd "$(dirname "$PADAPT")/.." && pwd)
doc="$PADAPT_SRC/docs/guide/cli.md"
fails=0
ok()  { echo "ok   $1"; }
bad() { echo "FAIL $1"; fails=$((fails + 1)); }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

rm -rf help && mkdir help
bash "$PADAPT_SRC/scripts/gen-man.sh" "$build" help > padapt.1 ||
  { echo "FAIL scripts/gen-man.sh"; exit 1; }
cmp -s padapt.1 "$PADAPT_SRC/docs/padapt.1" && ok "docs/padapt.1 is gen-man.sh's output" ||
  bad "docs/padapt.1 differs from the -h texts: run scripts/gen-man.sh BUILD > docs/padapt.1
$(diff padapt.1 "$PADAPT_SRC/docs/padapt.1" | head -20)"

# The comparison, in one process (fast on a loaded machine).
/usr/bin/python3 - "$doc" help <<'PY' || fails=$((fails + 1))
import re, sys
doc, helpdir = sys.argv[1], sys.argv[2]
# an option token: -name or --name after a blank or ( [ / , | ' " `
TOKEN = re.compile(r"""(?:^|(?<=[][ (/,|'"`]))(--?[a-z][A-Za-z0-9-]*)""", re.M)
def tokens(text):
    return set(TOKEN.findall(text))
lines = open(doc).read().split("\n")
def section(heading):
    out, on = [], False
    for line in lines:
        if line.startswith("## "):
            on = line == heading
        if on:
            out.append(line)
    return out
def table_options(sect):
    opts = set()
    for line in sect:
        cells = line.split("|")
        if line.startswith("|") and len(cells) > 2 and not re.fullmatch(r" *-+ *", cells[1]):
            opts |= tokens(cells[1])
    return opts
fails = 0
def check(ok, msg):
    global fails
    print(("ok   " if ok else "FAIL ") + msg)
    fails += not ok
for c in "top generate metric levelset stats convert adapt partition plot".split():
    name = "padapt -h" if c == "top" else "padapt %s -h" % c
    helptok = tokens(open("%s/help.%s" % (helpdir, c)).read())
    if c == "top":
        sect, table = lines, section("## Global options")
    else:
        sect = table = section("## `padapt %s`" % c)
        if not sect:
            check(False, "cli.md has no section '## `padapt %s`'" % c)
            continue
    missing = sorted(helptok - tokens("\n".join(sect)))
    check(not missing, "%s: every option in cli.md%s" %
          (name, "; missing: " + " ".join(missing) if missing else ""))
    documented = table_options(table)
    if helptok and not documented:
        check(False, "%s: no option table in its cli.md section" % name)
        continue
    unknown = sorted(documented - helptok)
    check(not unknown, "%s: cli.md's table options all known to -h%s" %
          (name, "; unknown: " + " ".join(unknown) if unknown else ""))
sys.exit(1 if fails else 0)
PY

[ $fails -eq 0 ] && echo "all checks passed" || { echo "check(s) failed"; exit 1; }
