#!/usr/bin/env bash
# memory_idle.sh -- after large progressive jobs are deleted, rayd gives their
# memory back: its own count (rayd_memory_bytes) returns to its idle figure
# (what stays is the scene cache's, rayd_cache_bytes), and so does its resident
# size, within a few MB, once the watcher has trimmed (a second or so): the
# heap is trimmed (malloc_trim) and the frames the core kept for the next
# render of their size (up to 32 MB) are unmapped once no render is left.
# Before, about 30 MB of those frames stayed resident for good.
# rayd-test: alone
. "$(dirname "$0")/lib/common.sh"

start_rayd --max-memory 1G --threads 2 --max-render-seconds 0
# counted outside the scene cache (kind scenes, as rayd_cache_bytes less its
# entries' own few hundred bytes): 0 at rest
uncached() { echo $(($(memory_total) - $(metric 'rayd_memory_bytes{kind="scenes"}'))); }
sleep 1
rss0=$(rayd_rss)
idle=$(uncached)

# 1024 samples: passes of 1, 2, 4, ... 1024; the jobs run one after another,
# each deleted once its first pass is done (running: a finished job keeps its
# image, by design)
ids=()
for i in 1 2 3 4; do
    scene "$T/p$i.json" 1024 1024 1024 spheres "$i"
    code=$(post_json '/v1/jobs?progressive=1' "$T/p$i.json")
    [ "$code" = 202 ] && ids+=("$(jfield "$T/body" id)")
done
check progressive_jobs_accepted "${#ids[@]} of 4 accepted" [ "${#ids[@]}" = 4 ]
pass_done() { req GET "/v1/jobs/$1" >/dev/null && [ "$(json "$T/body" 'j["passes"]["done"]')" -ge 1 ]; }
ncanceled=0
for id in "${ids[@]}"; do
    wait_until 120 pass_done "$id"
    req DELETE "/v1/jobs/$id" >/dev/null
    [ "$(jfield "$T/body" state)" = canceled ] && ncanceled=$((ncanceled + 1))
done
check deleted_while_running "$ncanceled of ${#ids[@]} canceled after their first pass; last: $(head -c 300 "$T/body")" \
    [ "$ncanceled" = 4 ]

counted_idle() { [ "$(uncached)" = "$idle" ]; }
check count_back_to_idle "counted outside the scene cache: $(uncached), idle $idle" \
    wait_until 30 counted_idle
check scenes_are_cached "scenes $(metric 'rayd_memory_bytes{kind="scenes"}'), cache $(metric rayd_cache_bytes)" \
    [ "$(metric 'rayd_memory_bytes{kind="scenes"}')" -le "$(metric rayd_cache_bytes)" ]
# the watcher trims once a second: a generous bound, 24 MB over the idle size
# (the four cached scenes and the allocator's own)
rss_back() { [ "$(rayd_rss)" -le $((rss0 + 25165824)) ]; }
wait_until 30 rss_back
echo "# VmRSS idle $rss0, after DELETE $(rayd_rss)"
if sanitized; then
    pass rss_back_to_idle # a sanitizer's shadow and quarantine make VmRSS meaningless
else
    check rss_back_to_idle "VmRSS $(rayd_rss) after DELETE, idle $rss0" wait_until 30 rss_back
fi

stop_rayd
check exit_clean "rayd exited $RAYD_RC" [ "$RAYD_RC" = 0 ]
exit $((NFAIL > 0))

