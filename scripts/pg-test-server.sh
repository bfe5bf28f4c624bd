#!/usr/bin/env bash
# A throwaway PostgreSQL server for the tests of the results database on
# a server (docs/campaigns.md, "A lab server"; tests/integration/campaign_pg.rs).
#
#   scripts/pg-test-server.sh COMMAND [ARG...]   runs COMMAND with the server up
#   scripts/pg-test-server.sh                    serves until interrupted
#
# It runs initdb into a new temporary directory, starts the server on
# 127.0.0.1 at a free port (its Unix socket in that directory), with
# password authentication (SCRAM) for the user `ledflicker` and a random
# password written to a password file of mode 0600. It exports
#   LEDFLICKER_TEST_PG  postgresql://ledflicker@127.0.0.1:PORT/postgres
#                       (no password: it comes from the password file)
#   PGPASSFILE          that file
# prints them, and on every exit stops the server and deletes the
# directory. initdb refuses to run as root: as root, the server runs as
# the unprivileged user `nobody`. When initdb is missing it installs
# Debian's `postgresql` (as root), else it fails: the tests never skip in
# CI.
set -euo pipefail

fail() {
    echo "pg-test-server: error: $*" >&2
    exit 1
}

find_bin() {
    local d
    for d in "$(dirname "$(command -v initdb 2>/dev/null || echo /nonexistent/x)")" \
        /usr/lib/postgresql/*/bin; do
        if [ -x "$d/initdb" ] && [ -x "$d/pg_ctl" ] && [ -x "$d/postgres" ]; then
            echo "$d"
            return 0
        fi
    done
    return 1
}

bin=$(find_bin || true)
if [ -z "$bin" ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "--- pg-test-server: installing postgresql (apt-get)" >&2
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq || fail "apt-get update failed"
        apt-get install -y -qq --no-install-recommends postgresql >/dev/null ||
            fail "cannot install the Debian package postgresql"
        bin=$(find_bin) || fail "postgresql is installed but initdb is not under /usr/lib/postgresql/*/bin"
    else
        fail "initdb not found; install PostgreSQL (e.g. sudo apt-get install postgresql)"
    fi
fi

work=$(mktemp -d /tmp/ledflicker-pg.XXXXXX)
as_server=()
if [ "$(id -u)" = 0 ]; then
    uid=$(id -u nobody) || fail "no user nobody to run the server as"
    gid=$(id -g nobody)
    chown "$uid:$gid" "$work"
    as_server=(setpriv --reuid="$uid" --regid="$gid" --clear-groups)
fi
chmod 0700 "$work"
started=no
cleanup() {
    if [ "$started" = yes ]; then
        "${as_server[@]}" "$bin/pg_ctl" stop -D "$work/data" -m fast -s >/dev/null 2>&1 || true
    fi
    rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

password=$(head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n')
(umask 077 && printf '%s\n' "$password" >"$work/pw")
[ ${#as_server[@]} -eq 0 ] || chown nobody "$work/pw"
"${as_server[@]}" "$bin/initdb" -D "$work/data" -U ledflicker --pwfile="$work/pw" \
    --auth=scram-sha-256 -E UTF8 --locale=C >"$work/initdb.log" 2>&1 ||
    {
        cat "$work/initdb.log" >&2
        fail "initdb failed"
    }
rm -f "$work/pw"

# A port nobody listens on; another process may take it before the
# server does, so a failed start tries another.
port=""
for _ in 1 2 3 4 5 6 7 8; do
    candidate=$((20000 + RANDOM % 30000))
    if (: <"/dev/tcp/127.0.0.1/$candidate") 2>/dev/null; then
        continue
    fi
    # Durability is of no use to a server deleted on exit: fsync off
    # keeps the tests fast.
    if "${as_server[@]}" "$bin/pg_ctl" start -D "$work/data" -w -t 60 -s -l "$work/server.log" \
        -o "-h 127.0.0.1 -p $candidate -k $work -c fsync=off -c synchronous_commit=off -c full_page_writes=off" \
        >/dev/null 2>&1; then
        port=$candidate
        started=yes
        break
    fi
done
if [ -z "$port" ]; then
    cat "$work/server.log" >&2 || true
    fail "the server did not start (log above)"
fi

passfile="$work/pgpass"
(umask 077 && printf '127.0.0.1:%s:*:ledflicker:%s\n' "$port" "$password" >"$passfile")
export PGPASSFILE="$passfile"
export LEDFLICKER_TEST_PG="postgresql://ledflicker@127.0.0.1:$port/postgres"
echo "--- pg-test-server: PostgreSQL $("$bin/postgres" --version | awk '{print $3}') on 127.0.0.1:$port (data in $work)" >&2
echo "LEDFLICKER_TEST_PG=$LEDFLICKER_TEST_PG" >&2
echo "PGPASSFILE=$PGPASSFILE" >&2

if [ $# -gt 0 ]; then
    status=0
    "$@" || status=$?
    exit "$status"
fi
echo "--- pg-test-server: serving until interrupted (Ctrl-C)" >&2
while :; do
    sleep 3600 &
    wait $! || true
done
