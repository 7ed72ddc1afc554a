#!/usr/bin/env bash
# durable_damaged.sh -- a --data-dir whose jobs.db is damaged (a page of an
# index zeroed: a disk's bad sector, a copy cut short), missing or empty
# beside finished images, or whose results/ is a file: rayd says what is
# wrong and does not start, deleting nothing; an image whose bytes changed
# on disk (a PNG's chunk CRCs, an EXR's CRC-32 after it) is not served.
#
# Before, the start-up sweep took every failed look-up in a damaged jobs.db
# for "no job names this file" and deleted every finished image, the load
# stopped at the first unreadable row without a word, and rayd listened with
# none of its jobs (404 job_unknown for every id it had answered 202 to) and
# refused every new one (503 store_failed "not an error").  A results/ that
# is a file was taken as the folder: no image could ever be written, and
# every finished job rendered again at each start.
source "$(dirname "$0")/lib/common.sh"

D=$T/data
start_rayd --threads 1 --data-dir "$D"
for i in 1 2 3; do
    scene "$T/j$i.json" 32 32 1 spheres "$i"
    post_json /v1/jobs "$T/j$i.json" >/dev/null
    jfield "$T/body" id >>"$T/ids"
done
for id in $(cat "$T/ids"); do wait_until 60 job_state_is "$id" succeeded; done
stop_rayd TERM
cp -r "$D" "$T/orig"
nimages=$(ls "$T/orig/results" | wc -l)
check damaged_setup "$nimages images" [ "$nimages" = 3 ]

# zero_page DIR INDEX: the root page of jobs.db's INDEX zeroed
zero_page() {
    python3 - "$1/jobs.db" "$2" <<'PY'
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
size = db.execute("PRAGMA page_size").fetchone()[0]
root = db.execute("SELECT rootpage FROM sqlite_master WHERE name = ?", (sys.argv[2],)).fetchone()[0]
db.close()
with open(sys.argv[1], "r+b") as f:
    f.seek((root - 1) * size)
    f.write(b"\0" * size)
PY
}
# refused DIR TEXT: rayd exits 1 on DIR, saying TEXT, without listening
refused() {
    timeout 15 "$RAYD" --bind 127.0.0.1 --port 0 --data-dir "$1" >"$T/bad.out" 2>"$T/bad.err"
    [ $? = 1 ] && grep -q -- "$2" "$T/bad.err" && ! [ -s "$T/bad.out" ]
}

# the index of the frames by state damaged: the sweep's look-ups fail
rm -rf "$T/c" && cp -r "$T/orig" "$T/c" && zero_page "$T/c" frames_ended
check damaged_frames_index_refused "$(tail -c 400 "$T/bad.err" 2>/dev/null)" \
    refused "$T/c" "jobs.db cannot be read"
check damaged_frames_index_images_kept "$(ls "$T/c/results" | wc -l) of 3 left" \
    [ "$(ls "$T/c/results" | wc -l)" = 3 ]

# the jobs' index damaged (results/ empty, so the load is the first to read it)
rm -rf "$T/c" && cp -r "$T/orig" "$T/c" && rm -f "$T/c/results/"* && zero_page "$T/c" sqlite_autoindex_jobs_2
check damaged_jobs_index_refused "$(tail -c 400 "$T/bad.err" 2>/dev/null)" \
    refused "$T/c" "jobs.db cannot be read"

# results/ a file
rm -rf "$T/c" && cp -r "$T/orig" "$T/c" && rm -rf "$T/c/results" && echo x >"$T/c/results"
check results_is_file_refused "$(tail -c 400 "$T/bad.err" 2>/dev/null)" refused "$T/c" "Not a directory"

# jobs.db deleted, or emptied, beside the images: SQLite would take it for a new store and the
# sweep delete every image (before: rayd listened, 0 of 3 images left, each job 404)
rm -rf "$T/c" && cp -r "$T/orig" "$T/c" && rm -f "$T/c/jobs.db" "$T/c/jobs.db-wal" "$T/c/jobs.db-shm"
check missing_db_refused "$(tail -c 400 "$T/bad.err" 2>/dev/null)" \
    refused "$T/c" "jobs.db is missing but results/ holds 3 images"
check missing_db_images_kept "$(ls "$T/c/results" | wc -l) of 3 left" [ "$(ls "$T/c/results" | wc -l)" = 3 ]
check missing_db_not_made "jobs.db made: $(ls "$T/c")" [ ! -e "$T/c/jobs.db" ]
rm -rf "$T/c" && cp -r "$T/orig" "$T/c" && rm -f "$T/c/jobs.db-wal" "$T/c/jobs.db-shm" && : >"$T/c/jobs.db"
check empty_db_refused "$(tail -c 400 "$T/bad.err" 2>/dev/null)" \
    refused "$T/c" "jobs.db is empty but results/ holds 3 images"
check empty_db_images_kept "$(ls "$T/c/results" | wc -l) of 3 left" [ "$(ls "$T/c/results" | wc -l)" = 3 ]
# results/ moved away as the message says: a new store starts
mv "$T/c/results" "$T/c/results.old"
start_rayd --threads 1 --data-dir "$T/c"
check new_store_after_move "$(req GET /v1/jobs/"$(head -n 1 "$T/ids")")" [ "$(req GET /v1/jobs/"$(head -n 1 "$T/ids")")" = 404 ]
stop_rayd TERM
check new_store_old_images_untouched "$(ls "$T/c/results.old" | wc -l) of 3" [ "$(ls "$T/c/results.old" | wc -l)" = 3 ]

# a first start on a results/ that holds no image: a folder (a volume's lost+found, results/ a
# mount point) and a write cut short.  Before, the folder counted as an image and the start was
# refused ("jobs.db is missing but results/ holds 1 image")
rm -rf "$T/f" && mkdir -p "$T/f/results/lost+found" && : >"$T/f/results/x.png.tmp"
start_rayd --threads 1 --data-dir "$T/f"
check first_start_folder_not_image "$(tail -c 300 "$T/rayd.err")" [ "$(req GET /healthz)" = 200 ]
stop_rayd TERM
check first_start_folder_kept "results/: $(ls "$T/f/results")" [ -d "$T/f/results/lost+found" ]

# flip_middle FILE: one bit of the byte in FILE's middle changed, its size kept (a bad sector)
flip_middle() {
    python3 - "$1" <<'PY'
import os, sys
with open(sys.argv[1], "r+b") as f:
    f.seek(os.path.getsize(sys.argv[1]) // 2)
    b = f.read(1)
    f.seek(-1, 1)
    f.write(bytes([b[0] ^ 0x10]))
PY
}

# one byte of an image changed, its size kept (a bad sector): before, the start-up check (sizes)
# passed it and GET served the changed bytes as the job's image (200)
rm -rf "$T/d" && cp -r "$T/orig" "$T/d"
first=$(head -n 1 "$T/ids")
img=$(ls "$T/d/results/$first"*.png)
flip_middle "$img"
start_rayd --threads 1 --data-dir "$T/d"
code=$(req GET "/v1/jobs/$first/image.png")
check damaged_image_not_served "$code $(head -c 300 "$T/body" | tr -cd '[:print:]')" \
    bash -c '[ "$0" = 410 ] && grep -q "damaged" "$1"' "$code" "$T/body"
check damaged_image_logged "$(tail -c 300 "$T/rayd.err")" grep -q "is damaged (a chunk's CRC" "$T/rayd.err"
n=0
for id in $(tail -n +2 "$T/ids"); do [ "$(req GET "/v1/jobs/$id/image.png")" = 200 ] && is_png "$T/body" && n=$((n + 1)); done
check damaged_image_others_served "$n of 2" [ "$n" = 2 ]
stop_rayd TERM

# the same for an EXR, which has no checksum of its own: rayd writes its CRC-32 after it (15
# bytes: "rayd-crc32:" and 4) and serves it only when that matches.  Before, a byte changed in
# results/ID.exr was served as the job's image (200)
rm -rf "$T/e" && start_rayd --threads 1 --data-dir "$T/e"
scene "$T/x.json" 32 32 1 spheres 7
post_json '/v1/jobs?format=exr' "$T/x.json" >/dev/null
xid=$(jfield "$T/body" id)
wait_until 60 job_state_is "$xid" succeeded
req GET "/v1/jobs/$xid/image.exr" >/dev/null && cp "$T/body" "$T/good.exr"
stop_rayd TERM
f=$T/e/results/$xid.exr
check exr_tail_written "$(stat -c %s "$f") bytes on disk, $(stat -c %s "$T/good.exr") served" \
    bash -c '[ "$(stat -c %s "$0")" = $(($(stat -c %s "$1") + 15)) ] &&
             cmp -s <(head -c "$(stat -c %s "$1")" "$0") "$1" &&
             [ "$(tail -c 15 "$0" | head -c 11)" = rayd-crc32: ]' "$f" "$T/good.exr"
rm -rf "$T/e2" && cp -r "$T/e" "$T/e2"
flip_middle "$f"
start_rayd --threads 1 --data-dir "$T/e"
code=$(req GET "/v1/jobs/$xid/image.exr")
check damaged_exr_not_served "$code $(head -c 300 "$T/body" | tr -cd '[:print:]')" \
    bash -c '[ "$0" = 410 ] && grep -q "damaged" "$1"' "$code" "$T/body"
check damaged_exr_logged "$(tail -c 300 "$T/rayd.err")" grep -q "is damaged (its CRC-32" "$T/rayd.err"
png_ok=no
[ "$(req GET "/v1/jobs/$xid/image.png")" = 200 ] && is_png "$T/body" && png_ok=yes
check damaged_exr_png_served "the job's PNG served: $png_ok" [ "$png_ok" = yes ]
stop_rayd TERM
# an EXR written before the tail (its row's bytes without it): served as it is, unchecked
f=$T/e2/results/$xid.exr
truncate -s -15 "$f"
python3 - "$T/e2/jobs.db" "$xid" <<'PY'
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.execute("UPDATE frames SET bytes = bytes - 15 WHERE job = ?", (sys.argv[2],))
db.commit()
PY
start_rayd --threads 1 --data-dir "$T/e2"
code=$(req GET "/v1/jobs/$xid/image.exr")
check untailed_exr_served "$code" bash -c '[ "$0" = 200 ] && cmp -s "$1" "$2"' "$code" "$T/body" "$T/good.exr"
stop_rayd TERM

# the undamaged copy starts, every job there
start_rayd --threads 1 --data-dir "$T/orig"
n=0
for id in $(cat "$T/ids"); do [ "$(req GET "/v1/jobs/$id/image.png")" = 200 ] && n=$((n + 1)); done
check undamaged_starts "$n of 3 images served" [ "$n" = 3 ]
# a job the store cannot record (another process holds jobs.db's write lock past the 5 s SQLite
# waits) is refused, saying SQLite's reason: it said "not an error", read after the rollback
python3 - "$T/orig/jobs.db" "$T/locked" <<'PY' &
import sqlite3, sys, time
db = sqlite3.connect(sys.argv[1], isolation_level=None)
db.execute("BEGIN EXCLUSIVE")
open(sys.argv[2], "w").close()
time.sleep(9)
db.execute("ROLLBACK")
PY
locker=$!
PIDS+=("$locker")
wait_until 10 test -e "$T/locked"
scene "$T/j9.json" 32 32 1 spheres 9
code=$(post_json /v1/jobs "$T/j9.json")
check store_failed_says_why "$code $(head -c 300 "$T/body")" \
    bash -c '[ "$0" = 503 ] && grep -q "store_failed" "$1" && grep -q "database is locked" "$1"' "$code" "$T/body"
wait "$locker"
exit $((NFAIL > 0))
