#!/usr/bin/env bash
# Re-creates tests/data/fountain-P11.db from the shared Strecha database:
# drops descriptors and raw matches (the mapper reads neither).
set -euo pipefail
cd "$(dirname "$0")/.."
src=../shared/data/strecha/fountain-P11/database.db
tmp=$(mktemp --suffix=.db)
cp "$src" "$tmp"
chmod u+w "$tmp"
sqlite3 "$tmp" "UPDATE descriptors SET rows=0, data=NULL; DELETE FROM matches; VACUUM;"
mv "$tmp" tests/data/fountain-P11.db
