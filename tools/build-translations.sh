#!/usr/bin/env bash
# Compile the GUI's gettext catalogs (.po -> .mo) next to their sources.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
LOCALE="$ROOT/src/gidabot_gui/locale"
[ -d "$LOCALE" ] || exit 0
for po in "$LOCALE"/*/LC_MESSAGES/*.po; do
  [ -e "$po" ] || continue
  msgfmt --check -o "${po%.po}.mo" "$po"
done
