#!/usr/bin/env bash
# A throw-away PostgreSQL server for the catalog tests, listening on 127.0.0.1 and a unix socket only.
#
#   tools/pg_test_server.sh install   # apt-get install postgresql when no initdb is found (root)
#   eval "$(tools/pg_test_server.sh start)"   # initdb + pg_ctl start + createdb; prints the export line
#   tools/pg_test_server.sh stop      # stop the server and remove its folder
#
# Settings (environment): MOCAPKIT_PG_PORT (default 54329), MOCAPKIT_PG_DIR (default
# /tmp/mocapkit-pg-<port>: data, socket and log). As root (CI) initdb/pg_ctl run as the postgres user
# through runuser; as another user they run as that user. Trust authentication: a test server only.
set -euo pipefail

PORT="${MOCAPKIT_PG_PORT:-54329}"
DIR="${MOCAPKIT_PG_DIR:-/tmp/mocapkit-pg-$PORT}"
DB=mocapkit_test

pg_bin() {
    local d
    d=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1 || true)
    if [ -n "$d" ] && [ -x "$d/initdb" ]; then echo "$d"; return; fi
    if command -v initdb >/dev/null 2>&1; then dirname "$(command -v initdb)"; return; fi
    return 1
}

as_pg() {
    if [ "$(id -u)" = 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi
}

case "${1:-}" in
install)
    if pg_bin >/dev/null; then exit 0; fi
    if [ "$(id -u)" != 0 ]; then
        echo "pg_test_server: no PostgreSQL found; install the 'postgresql' package (as root)" >&2
        exit 1
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q >&2
    apt-get install -y -q postgresql >&2
    ;;
start)
    BIN=$(pg_bin) || { echo "pg_test_server: no initdb found (run: $0 install)" >&2; exit 1; }
    mkdir -p "$DIR"
    if [ "$(id -u)" = 0 ]; then chown postgres "$DIR"; fi
    if [ ! -f "$DIR/data/PG_VERSION" ]; then
        as_pg "$BIN/initdb" -D "$DIR/data" --auth=trust -U postgres >"$DIR/initdb.log" 2>&1 \
            || { cat "$DIR/initdb.log" >&2; exit 1; }
    fi
    if ! as_pg "$BIN/pg_ctl" -D "$DIR/data" status >/dev/null 2>&1; then
        as_pg "$BIN/pg_ctl" -D "$DIR/data" -l "$DIR/server.log" -w -t 60 \
            -o "-c listen_addresses=127.0.0.1 -p $PORT -k $DIR" start >&2 \
            || { cat "$DIR/server.log" >&2; exit 1; }
    fi
    if ! as_pg "$BIN/psql" -h 127.0.0.1 -p "$PORT" -U postgres -tAc \
            "SELECT 1 FROM pg_database WHERE datname = '$DB'" | grep -q 1; then
        as_pg "$BIN/createdb" -h 127.0.0.1 -p "$PORT" -U postgres "$DB"
    fi
    echo "export MOCAPKIT_TEST_PG=postgresql://postgres@127.0.0.1:$PORT/$DB"
    ;;
stop)
    if [ -f "$DIR/data/PG_VERSION" ]; then
        BIN=$(pg_bin)
        as_pg "$BIN/pg_ctl" -D "$DIR/data" -m fast -w stop >&2 || true
    fi
    rm -rf "$DIR"
    ;;
*)
    echo "usage: $0 install|start|stop" >&2
    exit 2
    ;;
esac
