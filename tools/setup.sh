#!/usr/bin/env bash
# Idempotent set-up of a fresh machine for GidaBot: Debian packages, the venv, the catkin build.
# Usage: tools/setup.sh [apt|venv|build|all]   (run as root, or with sudo available, for apt)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
VENV="$ROOT/.venv"
STAMPS="$ROOT/.stamps"
mkdir -p "$STAMPS"

log() { printf '\033[1m[setup]\033[0m %s\n' "$*"; }

sudo_if_needed() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

do_apt() {
  local pkgs missing=()
  mapfile -t pkgs < <(grep -v '^\s*#' tools/apt-packages.txt | sed 's/#.*//' | awk 'NF{print $1}')
  for p in "${pkgs[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
      missing+=("$p")
    fi
  done
  if [ "${#missing[@]}" -eq 0 ]; then
    log "Debian packages: all ${#pkgs[@]} installed"
    return
  fi
  log "Debian packages missing: ${missing[*]}"
  sudo_if_needed apt-get update -q
  sudo_if_needed env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${missing[@]}"
}

do_venv() {
  if [ ! -x "$VENV/bin/python" ]; then
    log "creating venv $VENV from /usr/bin/python3 --system-site-packages"
    /usr/bin/python3 -m venv --system-site-packages "$VENV"
  fi
  local want have
  want="$(sha256sum requirements.txt | cut -d' ' -f1)"
  have="$(cat "$STAMPS/venv" 2>/dev/null || true)"
  if [ "$want" != "$have" ]; then
    log "installing pinned PyPI extras (requirements.txt)"
    "$VENV/bin/python" -m pip install -q --disable-pip-version-check -r requirements.txt
    echo "$want" > "$STAMPS/venv"
  else
    log "venv: up to date"
  fi
}

do_build() {
  log "catkin_make"
  export PATH="$VENV/bin:$PATH"
  catkin_make -DPYTHON_EXECUTABLE="$VENV/bin/python" -DCATKIN_ENABLE_TESTING=ON \
    -DCMAKE_BUILD_TYPE=Release >"$STAMPS/catkin_make.log" 2>&1 || {
      tail -40 "$STAMPS/catkin_make.log"; log "catkin_make failed (full log: $STAMPS/catkin_make.log)"; exit 1; }
  tools/build-translations.sh
  log "build: ok"
}

case "${1:-all}" in
  apt) do_apt ;;
  venv) do_venv ;;
  build) do_build ;;
  all) do_apt; do_venv; do_build ;;
  *) echo "usage: $0 [apt|venv|build|all]" >&2; exit 2 ;;
esac
