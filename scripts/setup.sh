#!/usr/bin/env bash
# Installs everything the build and the tests need on Debian 12 (bookworm), as
# root, from Debian packages only, and fetches COLMAP 3.8's source package
# (colmap 3.8-1) with `apt-get source` into the build tree. Safe to run twice:
# every step checks whether it is already done.
#
# Usage: scripts/setup.sh [BUILD_DIR]   (default: build)
set -euo pipefail

ROOT_DIR="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${1:-${ROOT_DIR}/build}"
COLMAP_VERSION="3.8-1"
COLMAP_SRC_DIR="${BUILD_DIR}/_deps/colmap-3.8"

log() { echo "[setup] $*"; }

if [[ "$(id -u)" != "0" ]]; then
  echo "[setup] error: run as root (installs Debian packages)" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive

PACKAGES=(
  build-essential cmake ninja-build ccache git pkg-config dpkg-dev
  libceres-dev libsuitesparse-dev libeigen3-dev
  libboost-program-options-dev libboost-filesystem-dev libboost-graph-dev
  libboost-system-dev libboost-test-dev
  libfreeimage-dev libflann-dev liblz4-dev libmetis-dev
  libgoogle-glog-dev libgflags-dev libsqlite3-dev sqlite3
  qtbase5-dev libqt5opengl5-dev libcgal-dev libglew-dev
  libgtest-dev libgmock-dev
  xvfb xauth libgl1-mesa-dri
  python3 python3-numpy gnuplot-nox time
)
# Extra packages a caller asks for (scripts/test.sh adds Debian's stock
# colmap 3.8 to check that it reads our models).
if [[ -n "${GLOMAP_EXTRA_PACKAGES:-}" ]]; then
  read -r -a extra <<< "${GLOMAP_EXTRA_PACKAGES}"
  PACKAGES+=("${extra[@]}")
fi

# 1. deb-src for the mirror apt already uses.
SRC_LIST=/etc/apt/sources.list.d/glomap-deb-src.sources
need_update=0
if ! grep -rqs "deb-src" /etc/apt/sources.list /etc/apt/sources.list.d/; then
  log "enabling deb-src in ${SRC_LIST}"
  uris="$(awk '/^URIs:/{print $2; exit}' /etc/apt/sources.list.d/debian.sources 2>/dev/null || true)"
  if [[ -z "${uris}" ]]; then
    uris="$(awk '/^deb /{print $2; exit}' /etc/apt/sources.list 2>/dev/null || true)"
  fi
  uris="${uris:-http://deb.debian.org/debian}"
  cat > "${SRC_LIST}" <<SRC
Types: deb-src
URIs: ${uris}
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
  need_update=1
fi

# 2. Packages.
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -gt 0 || ${need_update} -eq 1 ]]; then
  log "apt-get update"
  apt-get update -q
fi
if [[ ${#missing[@]} -gt 0 ]]; then
  log "installing: ${missing[*]}"
  apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  log "packages already installed"
fi

# 3. COLMAP 3.8 source package, signature and checksums verified by apt.
if [[ -f "${COLMAP_SRC_DIR}/.glomap-source-ok" ]]; then
  log "COLMAP ${COLMAP_VERSION} source already in ${COLMAP_SRC_DIR}"
else
  mkdir -p "${BUILD_DIR}/_deps"
  work="$(mktemp -d "${BUILD_DIR}/_deps/apt-source.XXXXXX")"
  # apt-get source refuses to run as root with _apt sandboxing when the folder
  # is not readable by _apt; give it a folder of its own.
  chmod 755 "${work}"
  chown _apt "${work}" 2>/dev/null || true
  log "apt-get source colmap=${COLMAP_VERSION}"
  (cd "${work}" && apt-get source -q --only-source "colmap=${COLMAP_VERSION}")
  dsc="$(ls "${work}"/colmap_*.dsc)"
  version="$(awk '/^Version:/{print $2}' "${dsc}")"
  if [[ "${version}" != "${COLMAP_VERSION}" ]]; then
    echo "[setup] error: expected colmap ${COLMAP_VERSION}, got ${version}" >&2
    exit 1
  fi
  changelog_version="$(head -1 "${work}/colmap-3.8/debian/changelog" | sed -E 's/.*\(([^)]+)\).*/\1/')"
  if [[ "${changelog_version}" != "${COLMAP_VERSION}" ]]; then
    echo "[setup] error: unpacked changelog says ${changelog_version}" >&2
    exit 1
  fi
  rm -rf "${COLMAP_SRC_DIR}"
  mv "${work}/colmap-3.8" "${COLMAP_SRC_DIR}"
  rm -rf "${work}"
  touch "${COLMAP_SRC_DIR}/.glomap-source-ok"
  log "COLMAP ${COLMAP_VERSION} source unpacked to ${COLMAP_SRC_DIR}"
fi
log "done"
