#!/usr/bin/env bash
# Make sure Debian's PostgreSQL server (initdb, pg_ctl) is installed; the ride store's PostgreSQL tests start a
# throw-away server from it on loopback. Installs the `postgresql` package with apt-get when it is missing.
# Exit status: 0 when the server binaries are there, 3 when they are missing and apt-get is not available,
# anything else when the installation failed.
set -euo pipefail

found() { ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || command -v initdb >/dev/null 2>&1; }

found && exit 0
if ! command -v apt-get >/dev/null 2>&1; then
    echo "PostgreSQL is not installed and apt-get is not available: install the PostgreSQL server by hand" >&2
    exit 3
fi
as_root=()
if [ "$(id -u)" != 0 ]; then as_root=(sudo -n); fi
"${as_root[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq --no-install-recommends postgresql >/dev/null
found
