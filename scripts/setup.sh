#!/usr/bin/env bash
# scanbench set-up on Debian 12: installs the Debian packages scanbench needs (only those that are
# missing) and extracts the classic test meshes from the libcgal-demo package into data/meshes/
# (ignored by git), and three.js from npm for the report's viewer. Idempotent: a second run installs
# and extracts nothing.
#
#   scripts/setup.sh            install + extract
#   scripts/setup.sh --check    only report what is missing (exit 1 if anything is)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

packages=(
  build-essential cmake git pkg-config ccache clang-format clang libclang-rt-14-dev
  libeigen3-dev libtbb-dev libembree-dev libopenvdb-dev libboost-iostreams-dev
  libopenimageio-dev openimageio-tools libopencv-core-dev fonts-dejavu-core
  nlohmann-json3-dev libfmt-dev libspdlog-dev libcli11-dev libnanoflann-dev libtinyobjloader-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libhwy-dev libcgal-dev libcgal-demo colmap libsqlite3-dev sqlite3 libssl-dev zlib1g-dev libopen3d-dev pcl-tools
  chromium python3-numpy python3-sklearn python3-open3d
  python3-dev pybind11-dev python3-pybind11 python3-pandas python3-pytest
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [[ "${1:-}" == "--check" ]]; then
  if ((${#missing[@]})); then echo "missing: ${missing[*]}"; exit 1; fi
  echo "all packages installed"; exit 0
fi

if ((${#missing[@]})); then
  echo "setup: installing ${#missing[@]} missing packages: ${missing[*]}"
  SUDO=""
  if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: all ${#packages[@]} packages already installed"
fi

# three.js for the report's 3D viewer: npm ci of the pinned harness/report-assets/package-lock.json
# into harness/report-assets/node_modules (ignored by git), again only when the lock changes.
assets="$here/harness/report-assets"
if ! command -v npm >/dev/null; then
  echo "setup: installing npm"
  SUDO=""; if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends npm >/dev/null
fi
if cmp -s "$assets/package-lock.json" "$assets/node_modules/.scanbench-lock"; then
  echo "setup: three.js already in $assets/node_modules"
else
  if (cd "$assets" && npm ci --no-audit --no-fund --loglevel=error >/dev/null); then
    cp "$assets/package-lock.json" "$assets/node_modules/.scanbench-lock"
    echo "setup: installed three.js into $assets/node_modules"
  else  # not fatal: a report then says how to install it
    echo "setup: npm ci failed in $assets; the report's 3D viewer needs it" >&2
  fi
fi

# Classic meshes (closed OFF files) from libcgal-demo, extracted once.
data="${SCANBENCH_DATA:-$here/data}"
meshes=(bunny00 fandisk armadillo camel elephant man eight cow knot hand femur)
tarball=/usr/share/doc/libcgal-demo/data.tar.gz
[[ -f $tarball ]] || tarball=/usr/share/doc/libcgal-dev/data.tar.gz
mkdir -p "$data/meshes"
todo=()
for m in "${meshes[@]}"; do
  [[ -s "$data/meshes/$m.off" ]] || todo+=("data/meshes/$m.off")
done
if ((${#todo[@]})); then
  if [[ ! -f $tarball ]]; then
    echo "setup: $tarball not found (package libcgal-demo); classic meshes unavailable" >&2
    exit 1
  fi
  tmp="$(mktemp -d)"
  tar -xzf "$tarball" -C "$tmp" "${todo[@]}"
  for f in "${todo[@]}"; do mv "$tmp/$f" "$data/meshes/"; done
  rm -rf "$tmp"
  echo "setup: extracted ${#todo[@]} meshes into $data/meshes"
else
  echo "setup: classic meshes already in $data/meshes"
fi
