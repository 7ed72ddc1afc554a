#!/usr/bin/env bash
# cli_denoise.sh -- rayd-render --denoise (and the scene's render.denoise):
# the same bytes on 1 and 2 threads, a --region equal to the crop of the
# denoised frame (pngcmp), smoother than the raw image; the biased controls
# --clamp-indirect and --filter-glossy change the image and are refused
# out of range with a usage error.
source "$(dirname "$0")/lib/common.sh"

CMP="$RAYD_BUILD/tests/tools/pngcmp"
scene "$T/c.json" 160 120 4 cornell

"$RENDER" "$T/c.json" -o "$T/raw.png" --threads 2 -q
"$RENDER" "$T/c.json" -o "$T/d1.png" --denoise --threads 1 -q
"$RENDER" "$T/c.json" -o "$T/d2.png" --denoise --threads 2 -q
check threads_same "--threads 1 and 2 differ" cmp -s "$T/d1.png" "$T/d2.png"
check denoise_changes "the denoised image is the raw one" bash -c "! cmp -s '$T/raw.png' '$T/d1.png'"

# regions: inside (the apron all round), at an edge, and one pixel
for reg in 70,40,33,21 0,0,40,120 159,119,1,1; do
    "$RENDER" "$T/c.json" -o "$T/r.png" --denoise --region "$reg" --threads 2 -q
    IFS=, read -r x y _ _ <<<"$reg"
    check "region_${reg//,/_}" "region $reg is not the crop of the denoised frame" \
        "$CMP" "$T/d1.png" "$T/r.png" "$x" "$y"
done

# the scene's render.denoise asks the same; an EXR too
python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s["render"]["denoise"]=True; print(json.dumps(s))' "$T/c.json" >"$T/cd.json"
"$RENDER" "$T/cd.json" -o "$T/sd.png" --threads 2 -q
check scene_key "render.denoise differs from --denoise" cmp -s "$T/sd.png" "$T/d1.png"

# smoother: the mean absolute difference of neighbouring pixels drops
rough() { python3 - "$1" <<'PY'
import sys, zlib, struct
d = open(sys.argv[1], "rb").read()
w, h = struct.unpack(">II", d[16:24])
i, idat = 8, b""
while i < len(d):
    n = struct.unpack(">I", d[i:i + 4])[0]
    if d[i + 4:i + 8] == b"IDAT": idat += d[i + 8:i + 8 + n]
    i += 12 + n
raw, rows, prev, s = zlib.decompress(idat), [], bytearray(w * 3), 0
for y in range(h):
    f, line = raw[y * (w * 3 + 1)], bytearray(raw[y * (w * 3 + 1) + 1:(y + 1) * (w * 3 + 1)])
    for x in range(w * 3):
        a = line[x - 3] if x >= 3 else 0
        b = prev[x]
        c = prev[x - 3] if x >= 3 else 0
        p = a + b - c
        pr = a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c
        line[x] = (line[x] + [0, a, b, (a + b) // 2, pr][f]) & 255
    rows.append(line)
    prev = line
for y in range(h):
    for x in range(3, w * 3): s += abs(rows[y][x] - rows[y][x - 3])
print(s // (w * h))
PY
}
r_raw=$(rough "$T/raw.png") r_den=$(rough "$T/d1.png")
check smoother "neighbour differences raw $r_raw, denoised $r_den" [ "$r_den" -lt $((r_raw / 2)) ]

# biased controls: they change the image; bad values are usage errors
"$RENDER" "$T/c.json" -o "$T/cl.png" --clamp-indirect 0.5 --threads 2 -q
check clamp_changes "--clamp-indirect 0.5 changed nothing" bash -c "! cmp -s '$T/raw.png' '$T/cl.png'"
"$RENDER" "$T/c.json" -o "$T/fg.png" --filter-glossy 0.8 --threads 2 -q
check filter_glossy_changes "--filter-glossy 0.8 changed nothing" bash -c "! cmp -s '$T/raw.png' '$T/fg.png'"
"$RENDER" "$T/c.json" -o "$T/cl1.png" --clamp-indirect 0.5 --threads 1 -q
check clamp_threads "--clamp-indirect: threads differ" cmp -s "$T/cl.png" "$T/cl1.png"
for bad in "--clamp-indirect -1" "--clamp-indirect x" "--filter-glossy 2" "--filter-glossy"; do
    "$RENDER" "$T/c.json" -o "$T/bad.png" $bad -q 2>"$T/err"
    rc=$?
    check "bad_${bad//[^a-z0-9]/_}" "exit $rc: $(cat "$T/err")" \
        bash -c "[ $rc = 2 ] && grep -q 'rayd-render: error: ${bad%% *}' '$T/err'"
done
