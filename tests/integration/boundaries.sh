#!/usr/bin/env bash
# boundaries.sh -- the server's run-time boundaries, read from its sources
# (issue 40): libmicrohttpd is named only by the transport (http.c and
# http_flow.c, wherever they live), so no handler builds a response; the
# scheduler writes no field of a task (task.c owns them); the work lock is
# taken only through work.c's wrappers, which know its owner; and no
# handler asks the scheduler why a render was cancelled.
set -u
cd "$(dirname "$0")/../.."
fail=0
ok() { echo "PASS $1"; }
ko() { echo "FAIL $1: $2"; fail=1; }

transport() { case "$(basename "$1")" in http.c|http_flow.c) return 0 ;; esac; return 1; }

bad=
for f in $(grep -rl --include='*.[ch]' '#include <microhttpd.h>' server); do
    transport "$f" || bad="$bad $f"
done
[ -z "$bad" ] && ok microhttpd_only_in_transport || ko microhttpd_only_in_transport "included by$bad"

bad=
for f in $(grep -rlE --include='*.[ch]' '\bMHD_[A-Za-z_]+' server); do
    transport "$f" || bad="$bad $f"
done
[ -z "$bad" ] && ok mhd_names_only_in_transport || ko mhd_names_only_in_transport "named in$bad"

sched=$(find server -name sched.c | head -n 1)
w=$(grep -nE '\bt->[a-z_]+(->[a-z_]+)? *([-+*/|&]?=[^=]|\+\+|--)' "$sched")
[ -z "$w" ] && ok sched_writes_no_task_field || ko sched_writes_no_task_field "$(echo "$w" | head -n 3 | tr '\n' ' ')"

raw=$(grep -rnE --include='*.c' 'pthread_(mutex_(un)?lock|cond_(timed)?wait)\([^)]*work_lock' server |
    grep -v '/work\.c:')
[ -z "$raw" ] && ok work_lock_only_through_wrappers || ko work_lock_only_through_wrappers "$(echo "$raw" | head -n 3 | tr '\n' ' ')"

asks=$(grep -rn --include='api*.c' -A2 'RAYD_E_CANCELED' server | grep 'sched_draining')
[ -z "$asks" ] && ok cancel_reason_from_result || ko cancel_reason_from_result "$asks"
exit $fail
