#!/usr/bin/env bash
# Extract the English source strings of the GUI and of the staff dashboard (gidabot_web, which shares these
# catalogs) into locale/gidabot_gui.pot and merge them into the Basque and Spanish catalogs (new strings
# arrive empty; the tests fail until translated).
# Compile with tools/build-translations.sh (make setup runs it).
set -euo pipefail
PKG="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$PKG"
xgettext -L Python --from-code=UTF-8 -k -k_ -kn_:1,2 -kN_ --add-comments=TRANSLATORS: \
  --package-name=gidabot_gui --msgid-bugs-address="dev@gidabot.invalid" --sort-by-file --add-location=file --no-wrap \
  -o locale/gidabot_gui.pot $(find src/gidabot_gui ../gidabot_web/src/gidabot_web -name "*.py" | sort)
for lang in eu es; do
  po="locale/$lang/LC_MESSAGES/gidabot_gui.po"
  if [ -f "$po" ]; then
    msgmerge --quiet --update --backup=none --no-fuzzy-matching --no-wrap --add-location=file "$po" locale/gidabot_gui.pot
  else
    msginit --no-translator --no-wrap --locale="$lang" -i locale/gidabot_gui.pot -o "$po"
  fi
done
