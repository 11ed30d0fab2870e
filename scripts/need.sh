#!/usr/bin/env bash
# need.sh CMD PACKAGE [EXTRA...] — make sure CMD exists; install Debian PACKAGE (and the EXTRA
# packages it needs beside it, e.g. fonts for a browser) when it is missing and we are root,
# otherwise say exactly what to install. Exit 0 when CMD is there afterwards.
# Used by the Makefile so `make run` and `make test` work on a fresh machine.
set -u
cmd=$1
pkg=$2
shift 2
extra="$*"
if command -v "$cmd" >/dev/null 2>&1; then
  exit 0
fi
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "wrc: installing $pkg (for $cmd) with apt-get" >&2
  stamp=/var/lib/apt/periodic/wrc-update-stamp
  if [ ! -f "$stamp" ] || [ -n "$(find "$stamp" -mmin +360 2>/dev/null)" ]; then
    DEBIAN_FRONTEND=noninteractive apt-get update -qq >&2 && mkdir -p "$(dirname "$stamp")" && touch "$stamp"
  fi
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$pkg" $extra >&2
  command -v "$cmd" >/dev/null 2>&1 && exit 0
  echo "wrc: installing $pkg did not provide $cmd" >&2
  exit 1
fi
echo "wrc: $cmd is missing; install the Debian package '$pkg' (for example: sudo apt-get install $pkg $extra)" >&2
exit 1
