#!/usr/bin/env bash
# Set-up of the cross targets (toolchains/README.md), from Debian packages only. Idempotent: apt runs only
# when something is missing, and a library built from its Debian source package is rebuilt only when its
# version changes.
#
#   toolchains/setup-targets.sh aarch64,powerpc     (setup.sh --targets aarch64,powerpc calls this)
#
# Both targets: the cross compilers and qemu-user >= 8.1 from bookworm-backports (bookworm's qemu 7.2 crashes
# in glibc's math functions for 32-bit PowerPC), pinned so that only qemu comes from backports.
# aarch64: Debian's arm64 multiarch packages (TurboJPEG, CppUTest, glib for LCM, libstdc++ to run); LCM's
#   arm64 runtime (liblcm1, liblcm-dev) is unpacked from the Debian packages into
#   $AREOMAP_CROSS_ROOT/aarch64-linux-gnu, since apt cannot co-install liblcm-dev for two architectures.
# powerpc: a Debian ports architecture that deb.debian.org does not serve, so CppUTest and libjpeg-turbo are
#   cross-built from their bookworm source packages into $AREOMAP_CROSS_ROOT/powerpc-linux-gnu; LCM's
#   runtime (it needs glib) is not built: the powerpc target has no udpm/file transport (see README).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="${AREOMAP_CROSS_ROOT:-/opt/areomap-cross}"
jobs="${AREOMAP_SETUP_JOBS:-$(nproc 2>/dev/null || echo 2)}"

usage() { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; }
case "${1:-}" in
  -h|--help) usage; exit 0 ;;
  "") usage >&2; exit 2 ;;
esac

want_aarch64=0
want_powerpc=0
IFS=',' read -r -a _targets <<<"$1"
for t in "${_targets[@]}"; do
  case "$t" in
    aarch64|arm64) want_aarch64=1 ;;
    powerpc|ppc) want_powerpc=1 ;;
    "") ;;
    *) echo "setup-targets: unknown target '$t' (known: aarch64, powerpc)" >&2; exit 2 ;;
  esac
done

as_root=()
if [ "$(id -u)" != 0 ]; then as_root=(sudo); fi
apt_get() {
  DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get -o DPkg::Lock::Timeout=600 -y -q "$@"
}
installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }
updated=0
apt_update() {
  if [ "$updated" = 0 ]; then apt_get update; updated=1; fi
}

# --- apt sources: bookworm-backports (qemu only) and deb-src (source packages of the powerpc libraries) ---
sources_changed=0
backports=/etc/apt/sources.list.d/areomap-backports.sources
if [ ! -f "$backports" ]; then
  "${as_root[@]}" tee "$backports" >/dev/null <<'SRC'
# areomap (toolchains/setup-targets.sh): qemu-user >= 8.1 for the cross targets; pinned in
# /etc/apt/preferences.d/areomap-qemu so that nothing else is taken from backports.
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
  sources_changed=1
fi
pin=/etc/apt/preferences.d/areomap-qemu
if [ ! -f "$pin" ]; then
  "${as_root[@]}" tee "$pin" >/dev/null <<'PIN'
# areomap (toolchains/setup-targets.sh): only qemu-user comes from bookworm-backports.
Package: qemu-user qemu-user-static qemu-user-binfmt
Pin: release n=bookworm-backports
Pin-Priority: 990

Package: *
Pin: release n=bookworm-backports
Pin-Priority: 100
PIN
fi
if [ "$want_powerpc" = 1 ]; then
  debsrc=/etc/apt/sources.list.d/areomap-src.sources
  if [ ! -f "$debsrc" ]; then
    "${as_root[@]}" tee "$debsrc" >/dev/null <<'SRC'
# areomap (toolchains/setup-targets.sh): Debian source packages, to cross-build the powerpc libraries.
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: bookworm
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
    sources_changed=1
  fi
fi
if [ "$want_aarch64" = 1 ] && ! dpkg --print-foreign-architectures | grep -qx arm64; then
  "${as_root[@]}" dpkg --add-architecture arm64
  sources_changed=1
fi
if [ "$sources_changed" = 1 ]; then apt_update; fi

# --- packages ---
packages=(qemu-user cmake ninja-build pkg-config liblcm-bin libeigen3-dev)
if [ "$want_aarch64" = 1 ]; then
  packages+=(g++-aarch64-linux-gnu libturbojpeg0-dev:arm64 libjpeg62-turbo-dev:arm64 libcpputest-dev:arm64
             libglib2.0-0:arm64 libstdc++6:arm64)
fi
if [ "$want_powerpc" = 1 ]; then
  packages+=(g++-powerpc-linux-gnu dpkg-dev)
fi
missing=()
for p in "${packages[@]}"; do installed "$p" || missing+=("$p"); done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup-targets: installing ${#missing[@]} Debian packages: ${missing[*]}"
  apt_update
  apt_get install --no-install-recommends "${missing[@]}"
fi
qemu_version="$(dpkg-query -W -f='${Version}' qemu-user)"
if ! dpkg --compare-versions "$qemu_version" ge 1:8.1; then
  echo "setup-targets: qemu-user $qemu_version < 8.1; installing it from bookworm-backports"
  apt_update
  apt_get install --no-install-recommends -t bookworm-backports qemu-user
fi

# --- aarch64: LCM's arm64 runtime, unpacked from the Debian packages ---
if [ "$want_aarch64" = 1 ]; then
  dest="$root/aarch64-linux-gnu"
  lcm_version="$(dpkg-query -W -f='${Version}' liblcm-bin)"
  stamp="$dest/.lcm-$lcm_version"
  if [ ! -f "$stamp" ]; then
    echo "setup-targets: unpacking liblcm1:arm64 and liblcm-dev:arm64 $lcm_version into $dest"
    work="$(mktemp -d)"; chmod 755 "$work"  # apt-get downloads as _apt
    (cd "$work" && apt-get download "liblcm1:arm64=$lcm_version" "liblcm-dev:arm64=$lcm_version")
    "${as_root[@]}" mkdir -p "$dest"
    for deb in "$work"/*.deb; do "${as_root[@]}" dpkg -x "$deb" "$dest"; done
    rm -rf "$work"
    "${as_root[@]}" rm -f "$dest"/.lcm-*
    "${as_root[@]}" touch "$stamp"
  fi
fi

# --- powerpc: CppUTest and libjpeg-turbo cross-built from their bookworm source packages ---
# build_from_source PACKAGE CMAKE-ARGS...: apt-get source, then CMake with the powerpc compilers, static
# libraries installed into $root/powerpc-linux-gnu.
build_from_source() {
  local pkg="$1"; shift
  local dest="$root/powerpc-linux-gnu"
  local version
  version="$(apt-cache showsrc "$pkg" | sed -n 's/^Version: //p' | head -1)"
  if [ -z "$version" ]; then
    apt_update
    version="$(apt-cache showsrc "$pkg" | sed -n 's/^Version: //p' | head -1)"
  fi
  local stamp="$dest/.$pkg-$version"
  if [ -f "$stamp" ]; then return 0; fi
  echo "setup-targets: cross-building $pkg $version for powerpc into $dest"
  local work
  work="$(mktemp -d)"; chmod 755 "$work"  # apt-get downloads as _apt
  (cd "$work" && apt-get source -q --download-only "$pkg=$version" >/dev/null &&
     dpkg-source -x --skip-patches ./*.dsc src >/dev/null)
  # The Debian patches apply to the packaged build (docs, paths); the library sources are upstream's.
  cmake -S "$work/src" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
        -DCMAKE_TOOLCHAIN_FILE="$here/powerpc-linux-gnu.cmake" \
        -DCMAKE_INSTALL_PREFIX="$dest" "$@" >"$work/configure.log" ||
    { cat "$work/configure.log" >&2; exit 1; }
  cmake --build "$work/build" -j "$jobs" >"$work/build.log" || { tail -50 "$work/build.log" >&2; exit 1; }
  "${as_root[@]}" cmake --install "$work/build" >/dev/null
  rm -rf "$work"
  "${as_root[@]}" rm -f "$dest/.$pkg-"*
  "${as_root[@]}" touch "$stamp"
}
if [ "$want_powerpc" = 1 ]; then
  build_from_source cpputest -DCMAKE_INSTALL_LIBDIR=lib -DTESTS=OFF -DBUILD_TESTING=OFF -DEXTENSIONS=ON \
                    -DMEMORY_LEAK_DETECTION=OFF -DLONGLONG=ON
  # libjpeg-turbo's own GNUInstallDirs resolves a relative libdir against the working directory.
  build_from_source libjpeg-turbo -DCMAKE_INSTALL_LIBDIR="$root/powerpc-linux-gnu/lib" \
                    -DENABLE_SHARED=OFF -DENABLE_STATIC=ON -DWITH_SIMD=OFF -DWITH_JAVA=OFF \
                    -DWITH_TURBOJPEG=ON -DCMAKE_POSITION_INDEPENDENT_CODE=ON
  # LCM's headers (the generated message code needs only lcm_coretypes.h, which encodes big-endian byte by
  # byte on any host) from the same Debian version as lcm-gen, unpacked from liblcm-dev.
  dest="$root/powerpc-linux-gnu"
  lcm_version="$(dpkg-query -W -f='${Version}' liblcm-bin)"
  stamp="$dest/.lcm-headers-$lcm_version"
  if [ ! -f "$stamp" ]; then
    work="$(mktemp -d)"; chmod 755 "$work"  # apt-get downloads as _apt
    (cd "$work" && apt-get download "liblcm-dev=$lcm_version" >/dev/null && dpkg -x ./*.deb x)
    "${as_root[@]}" mkdir -p "$dest/include"
    "${as_root[@]}" cp -r "$work/x/usr/include/lcm" "$dest/include/"
    rm -rf "$work"
    "${as_root[@]}" rm -f "$dest"/.lcm-headers-*
    "${as_root[@]}" touch "$stamp"
  fi
fi

echo "setup-targets: ready ($1; qemu-user $(dpkg-query -W -f='${Version}' qemu-user), libraries in $root)"
