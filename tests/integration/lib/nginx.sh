# lib/nginx.sh -- docker/nginx.conf on loopback, for the tests and benches.
#
# nginx_conf ROOT DIR PORT ADDR...: writes DIR/nginx.conf, docker/nginx.conf
# of ROOT with one "# @node" line per ADDR (host:port) in place of the
# file's own (keeping that line's parameters, so max_fails and the like are
# the ones docker/nginx.conf ships), "listen 127.0.0.1:PORT" in place of the
# "# @listen" line, and DIR/cache, DIR/log and DIR/nginx.pid in place of
# /var/cache/nginx, /var/log/nginx and /var/run/nginx.pid.  Makes DIR/cache
# and DIR/log.  Only sourced (bash); no process is started here.
nginx_conf() {
    local root=$1 dir=$2 port=$3 addrs
    shift 3
    addrs="$*"
    mkdir -p "$dir/cache" "$dir/log"
    awk -v addrs="$addrs" -v port="$port" '
        BEGIN { n = split(addrs, a, " ") }
        /^ *server .*# @node/ {
            if (!innode) {
                line = $0
                sub(/ *# @node.*$/, "", line)
                for (i = 1; i <= n; i++) {
                    l = line
                    sub(/server [^ ;]+/, "server " a[i], l)
                    print l " # @node"
                }
            }
            innode = 1
            next
        }
        { innode = 0 }
        /^ *listen .*# @listen/ { print "        listen 127.0.0.1:" port "; # @listen"; next }
        { print }' "$root/docker/nginx.conf" |
        sed -e "s#/var/cache/nginx#$dir/cache#g" -e "s#/var/log/nginx#$dir/log#g" \
            -e "s#/var/run/nginx.pid#$dir/nginx.pid#g" >"$dir/nginx.conf"
}

# nginx_opts: the -g directives for a foreground nginx run by this user
nginx_opts() {
    local g="daemon off;"
    [ "$(id -u)" = 0 ] && g+=" user root;"
    echo "$g"
}

# nginx_start DIR ADDR...: (tests only, after common.sh) writes DIR's
# config with nginx_conf, checks it (a FAIL line and exit when nginx refuses
# it), and starts $NGINX in the foreground: NGINX_PID, listening on
# 127.0.0.1:NGINX_PORT.  nginx needs its port in the config, so a free one
# is picked; should another program take it first, nginx cannot bind and
# exits, and another port is tried.  The EXIT trap then stops nginx with
# TERM before common.sh's cleanup, since nginx's workers outlive a
# SIGKILLed master.
nginx_start() {
    local dir=$1 opts try
    shift
    opts=$(nginx_opts)
    trap nginx_cleanup EXIT
    for try in 1 2 3 4 5; do
        NGINX_PORT=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
        nginx_conf "$RAYD_ROOT" "$dir" "$NGINX_PORT" "$@"
        if ! "$NGINX" -t -q -p "$dir" -c "$dir/nginx.conf" -e "$dir/log/error.log" -g "$opts" \
            2>"$T/nginx-t.err"; then
            echo "FAIL nginx_conf_valid: $(head -c 400 "$T/nginx-t.err")"
            exit 1
        fi
        "$NGINX" -p "$dir" -c "$dir/nginx.conf" -e "$dir/log/error.log" -g "$opts" 2>"$T/nginx.err" &
        NGINX_PID=$!
        # up: its master listens on the port; or gone (the port was taken)
        wait_until 60 nginx_listening_or_gone
        [ "$(listen_port "$NGINX_PID")" = "$NGINX_PORT" ] && break
        kill -TERM "$NGINX_PID" 2>/dev/null
        wait "$NGINX_PID" 2>/dev/null
        NGINX_PID=
    done
    if [ -z "$NGINX_PID" ]; then
        echo "FAIL nginx_start: nginx never listened: $(tail -c 400 "$T/nginx.err" "$dir/log/error.log" 2>/dev/null)"
        exit 1
    fi
    echo "PASS nginx_conf_valid"
}
nginx_listening_or_gone() {
    ! kill -0 "$NGINX_PID" 2>/dev/null || [ "$(listen_port "$NGINX_PID")" = "$NGINX_PORT" ]
}
nginx_cleanup() {
    ours "$NGINX_PID" && kill -TERM "$NGINX_PID" 2>/dev/null && wait "$NGINX_PID" 2>/dev/null
    cleanup
}

# nginx_stop_check_nodes N: stops nginx gracefully, then FAILs for any
# sanitizer report (SANITIZE=1 builds) in the logs $T/node1.err..$T/nodeN.err.
nginx_stop_check_nodes() {
    local i
    kill -QUIT "$NGINX_PID" 2>/dev/null
    wait "$NGINX_PID" 2>/dev/null
    for i in $(seq 1 "$1"); do
        if grep -Eq 'ERROR: (Address|Leak)Sanitizer|runtime error:' "$T/node$i.err"; then
            fail "node${i}_sanitizer" "$(grep -Em 3 'Sanitizer|runtime error' "$T/node$i.err")"
        fi
    done
}
