#!/usr/bin/env bash
# A scene nothing lights renders black; rayd says so instead of leaving the
# user to wonder: rayd-render warns on stderr (with --quiet too) and exits
# 0, the server's image carries X-Rayd-Warning (fresh and from the result
# cache), and a job's 202 has it as a header and in "warnings".  A lit scene, an emissive one, one with a background colour or
# an environment draws no warning.
source "$(dirname "$0")/lib/common.sh"
R="$RAYD_BUILD/rayd-render"

unlit='{"camera": {"position": [0, 0, 5]}, "render": {"width": 8, "height": 8},
  "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]}'
echo "$unlit" >"$T/unlit.json"
"$R" "$T/unlit.json" -o "$T/unlit.png" --quiet 2>"$T/err"; rc=$?
check cli_unlit_warns "exit $rc: $(cat "$T/err")" \
    bash -c "[ $rc = 0 ] && grep -q '^rayd-render: warning: nothing in the scene gives light' '$T/err'"

# lit_no_warning NAME JSON: renders without a warning.
lit_no_warning() {
    echo "$2" >"$T/$1.json"
    "$R" "$T/$1.json" -o "$T/$1.png" 2>"$T/$1.err"; local rc=$?
    check "cli_${1}_no_warning" "exit $rc: $(cat "$T/$1.err")" \
        bash -c "[ $rc = 0 ] && ! grep -q warning '$T/$1.err'"
}
lit_no_warning light '{"render": {"width": 8, "height": 8}, "lights": [{"type": "point", "position": [0, 5, 5]}],
  "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]}'
lit_no_warning emissive '{"render": {"width": 8, "height": 8}, "materials": {"lamp": {"emission": [1, 1, 1]}},
  "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "lamp"}]}'
lit_no_warning background '{"render": {"width": 8, "height": 8, "background": [0.2, 0.3, 0.4]},
  "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]}'
lit_no_warning environment '{"render": {"width": 8, "height": 8, "environment": {"color": [1, 1, 1]}},
  "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]}'

start_rayd --threads 1
for round in fresh cached; do
    code=$(curl -s -m 60 -w '%{http_code}' -D "$T/h" -o "$T/img" -H 'Content-Type: application/json' \
        --data-binary @"$T/unlit.json" "$URL/v1/render")
    warn=$(tr -d '\r' <"$T/h" | sed -n 's/^X-Rayd-Warning: //Ip')
    check "api_unlit_header_$round" "status $code, warning '$warn'" \
        bash -c "[ $code = 200 ] && [[ '$warn' == unlit:* ]]"
done
code=$(curl -s -m 60 -w '%{http_code}' -D "$T/h" -o "$T/img" -H 'Content-Type: application/json' \
    --data-binary @"$T/light.json" "$URL/v1/render")
check api_lit_no_header "status $code: $(cat "$T/h")" \
    bash -c "[ $code = 200 ] && ! grep -qi '^X-Rayd-Warning' '$T/h'"
# a job of it: the 202 says so in its JSON and its header; a lit one does not
code=$(post_json /v1/jobs "$T/unlit.json")
in_json=$(json "$T/body" 'j["warnings"][0]' 2>/dev/null)
in_header=$(header X-Rayd-Warning)
check job_unlit_warns "status $code: '$in_json' / '$in_header'" bash -c \
    "[ $code = 202 ] && [ -n \"\$1\" ] && [ \"\$1\" = \"\$2\" ] && [[ \"\$1\" == unlit:* ]]" _ "$in_json" "$in_header"
code=$(post_json /v1/jobs "$T/light.json")
in_header=$(header X-Rayd-Warning)
check job_lit_no_warning "status $code: $(head -c 400 "$T/body") / '$in_header'" \
    bash -c "[ $code = 202 ] && ! grep -q warnings '$T/body' && [ -z '$in_header' ]"
stop_rayd
check rayd_exit_0 "exit $RAYD_RC" [ "$RAYD_RC" = 0 ]
