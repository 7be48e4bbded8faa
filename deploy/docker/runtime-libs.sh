#!/usr/bin/env bash
# Run in a build stage: runtime-libs.sh OUT BINARY...
# Lists in OUT/packages.txt the Debian packages that own the shared libraries
# the binaries load, so the runtime stage installs exactly those (and not the
# -dev packages of the build stage). Libraries no package owns (CUDA's
# libcudart from /usr/local/cuda) are copied to OUT/lib instead.
# Libraries opened with dlopen (EGL vendor drivers, Mesa's DRI drivers) are not
# in ldd's output: the Dockerfiles name those packages themselves.
set -euo pipefail
out=$1
shift
mkdir -p "$out/lib"
: >"$out/packages.txt"

if ldd "$@" | grep -q 'not found'; then
  ldd "$@" | grep 'not found' >&2
  echo "runtime-libs: unresolved libraries (set LD_LIBRARY_PATH for them)" >&2
  exit 1
fi

ldd "$@" | awk '/=> \//{print $3}' | sort -u | while read -r lib; do
  # Match on ARCH-DIR/NAME: with usrmerge a library may be registered under
  # /lib or /usr/lib, and NAME alone also matches /lib32 copies (libc6-i386).
  pattern="*/$(basename "$(dirname "$lib")")/$(basename "$lib")"
  owner=$(dpkg -S "$pattern" 2>/dev/null | head -1 | sed 's/[:,].*//') || true
  case "$lib" in /usr/local/*) owner="" ;; esac  # not from Debian even when dpkg knows it
  if [ -n "$owner" ]; then
    echo "$owner" >>"$out/packages.txt"
  else
    cp -L "$lib" "$out/lib/"
  fi
done
sort -u -o "$out/packages.txt" "$out/packages.txt"
echo "runtime-libs: $(wc -l <"$out/packages.txt") packages, $(find "$out/lib" -type f | wc -l) copied libraries" >&2
