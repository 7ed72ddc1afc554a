#!/usr/bin/env bash
# cluster_frames_order.sh -- rayd --redis: a frame-range job's frames are
# assembled as they complete, not after every tile of the whole job.  A
# frame's assembly is queued on the high-priority stream, so the node takes
# it before the tiles of the job's later frames: with the tiles of frame 0
# (and one more) let through the test gate and the rest held, frame 0 is
# done and served, and the job's progress and eta_s say so.  Stopped by PID.
source "$(dirname "$0")/lib/common.sh"
source "$(dirname "$0")/lib/redis.sh"

cp "$RAYD_ROOT/tests/integration/lib/anim4.json" "$T/anim.json" # frames 0-3, 64x32
start_redis
start_node 1 --threads 1 --cluster-tile 32 --test-gate 0 --redis "$REDIS_URL"
URL=${NODE_URL[1]}
code=$(curl -s -o "$T/post.json" -w '%{http_code}' -H 'Content-Type: application/json' \
    --data-binary @"$T/anim.json" "$URL/v1/jobs?frames=0-3")
ID=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["id"])' "$T/post.json" 2>/dev/null)
check posted "POST gave $code: $(head -c 300 "$T/post.json")" [ "$code" = 202 -a -n "$ID" ]
curl -s -X POST "$URL/v1/test/gate?tiles=3" >/dev/null # frame 0's two tiles, and one of frame 1
frame0_done() { curl -s "$URL/v1/jobs/$ID" | grep -q '"done":1,'; }
wait_until 60 frame0_done
check frame0_done_first "$(curl -s "$URL/v1/jobs/$ID")" frame0_done
check frame0_served "frames/0.png gave $(curl -s -o "$T/f0.png" -w '%{http_code}' "$URL/v1/jobs/$ID/frames/0.png")" \
    bash -c "[ \$(curl -s -o '$T/f0.png' -w '%{http_code}' '$URL/v1/jobs/$ID/frames/0.png') = 200 ]"
"$RENDER" "$T/anim.json" --frame 0 -o "$T/r0.png" -q --threads 1
check frame0_as_cli "frame 0 differs from rayd-render --frame 0" cmp -s "$T/f0.png" "$T/r0.png"
check progress_and_eta "$(curl -s "$URL/v1/jobs/$ID")" bash -c \
    "curl -s '$URL/v1/jobs/$ID' | grep '\"progress\":0.2500,' | grep -q '\"eta_s\":[0-9]'"
# tiles_done / tiles_total count frames, as a single node's frame-range job (api.md)
check tiles_count_frames "$(curl -s "$URL/v1/jobs/$ID")" bash -c \
    "curl -s '$URL/v1/jobs/$ID' | grep -q '\"tiles_done\":1,\"tiles_total\":4,'"
curl -s -X POST "$URL/v1/test/gate?tiles=open" >/dev/null
wait_until 60 bash -c "curl -s '$URL/v1/jobs/$ID' | grep -q '\"state\":\"succeeded\"'"
check job_succeeded "$(curl -s "$URL/v1/jobs/$ID")" bash -c "curl -s '$URL/v1/jobs/$ID' | grep -q '\"done\":4,'"
# its event stream: frames, no tile or progress events (as one node's)
curl -s -m 10 "$URL/v1/jobs/$ID/events" >"$T/events.txt"
check events_frames_only "$(grep '^event:' "$T/events.txt" | sort | uniq -c | tr '\n' ' ')" bash -c \
    "[ \$(grep -c '^event: frame' '$T/events.txt') = 4 ] && ! grep -q '^event: tile\|^event: progress' '$T/events.txt'"
exit $NFAIL
