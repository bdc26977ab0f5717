#!/usr/bin/env bash
# Regenerates the parts of docs/ that come from the engine's declarations: the option tables of
# docs/cli.md (between the GENERATED markers) and docs/schemas/requests/*.json. The tests fail
# when these are stale (tests/engine/cli/conventions_test.cpp).
#   bash scripts/gen-docs.sh [BUILD_DIR]
set -euo pipefail
BUILD=${1:-build}
B="$BUILD/app/btfsim"
[ -x "$B" ] || { echo "gen-docs: build btfsim first (make build)" >&2; exit 1; }
mkdir -p docs/schemas/requests
for c in simulate compress compare export plan bench study brdf slice render info; do
  "$B" schema --command "$c" -o "docs/schemas/requests/$c.json"
done
gen=$(mktemp)
"$B" cli-doc -o "$gen"
python3 - "$gen" <<'PY'
import sys
doc = open("docs/cli.md", encoding="utf-8").read()
begin, end = "<!-- BEGIN GENERATED OPTIONS -->\n", "<!-- END GENERATED OPTIONS -->"
gen = open(sys.argv[1], encoding="utf-8").read()
i, j = doc.index(begin) + len(begin), doc.index(end)
open("docs/cli.md", "w", encoding="utf-8").write(doc[:i] + gen + doc[j:])
PY
rm -f "$gen"
echo "gen-docs: docs/cli.md and docs/schemas/requests/ are current"
