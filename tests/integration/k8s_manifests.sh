#!/usr/bin/env bash
# k8s_manifests.sh -- docker/k8s/ and docker/compose.yml validated offline
# (no cluster, no Docker, no network).
#
# tests/k8s/validate.mjs checks every document against the Kubernetes and
# prometheus-operator schemas (kubernetes-models from npm, pinned in
# tests/k8s/package-lock.json and installed by `make test` like the browser
# tests' packages) and the rules the deployment relies on (pinned image,
# token for Prometheus, no 404 retries, the Redis StatefulSet with its
# volume, AOF and password Secret, --redis on every pod, ...).
# tests/k8s/compose.mjs checks docker/compose.yml against the Compose
# Specification's schema (tests/k8s/compose-spec.json, with ajv) and, with
# docker/nginx.conf, by the same kind of rules (Redis with AOF on a volume,
# three nodes with --redis, the upstream, no http_404 retry).  A manifest
# with a wrong type, a compose file with a wrong depends_on condition, and
# copies of the files with AOF off or the 404 retry back, must be refused,
# so both checkers are shown able to fail.  When node or the packages cannot be had
# (no npm, no registry), the test says SKIP and passes nothing.
source "$(dirname "$0")/lib/common.sh"

K8S=$RAYD_ROOT/tests/k8s
if ! command -v node >/dev/null 2>&1; then
    echo "SKIP k8s_manifests: node not found (Debian's nodejs)"
    exit 0
fi
if [ ! -d "$K8S/node_modules/kubernetes-models" ] && command -v npm >/dev/null 2>&1; then
    (cd "$K8S" && timeout 300 npm ci --no-audit --no-fund --loglevel=error) >"$T/npm.log" 2>&1
fi
if [ ! -d "$K8S/node_modules/kubernetes-models" ]; then
    echo "SKIP k8s_manifests: the validator's npm packages could not be installed: $(tail -n 2 "$T/npm.log" 2>/dev/null | tr '\n' ' ')"
    exit 0
fi

(cd "$RAYD_ROOT" && node tests/k8s/validate.mjs docker/k8s) 2>"$T/validate.err"
rc=$?
[ -s "$T/validate.err" ] && fail validator_ran "$(head -c 400 "$T/validate.err")"
check validator_exit "exit $rc" [ $rc = 0 ]

# the self-test: a Deployment whose replicas is a string
cat >"$T/bad.yaml" <<'YAML'
apiVersion: apps/v1
kind: Deployment
metadata: {name: bad}
spec:
  replicas: three
  selector: {matchLabels: {app: bad}}
  template:
    metadata: {labels: {app: bad}}
    spec: {containers: [{name: c, image: "x:1"}]}
YAML
node "$K8S/validate.mjs" --expect-invalid "$T/bad.yaml"

# the compose file and nginx.conf
(cd "$RAYD_ROOT" && node tests/k8s/compose.mjs docker/compose.yml docker/nginx.conf) 2>"$T/compose.err"
rc=$?
[ -s "$T/compose.err" ] && fail compose_checker_ran "$(head -c 400 "$T/compose.err")"
check compose_exit "exit $rc" [ $rc = 0 ]

# the rules fail on copies with AOF off and the 404 retry back
mkdir -p "$T/k8s-bad"
cp -r "$RAYD_ROOT/docker/k8s/." "$T/k8s-bad/"
sed -i 's/"--appendonly", "yes"/"--appendonly", "no"/' "$T/k8s-bad/redis.yaml"
sed -i 's/"error timeout http_503 non_idempotent"/"error timeout http_503 http_404 non_idempotent"/' \
    "$T/k8s-bad/service.yaml"
node "$K8S/validate.mjs" "$T/k8s-bad" >"$T/k8s-bad.out" 2>&1
check rules_refuse_aof_off "$(grep -c . "$T/k8s-bad.out") lines, no FAIL redis_aof_on" \
    grep -q '^FAIL redis_aof_on:' "$T/k8s-bad.out"
check rules_refuse_404_retry "no FAIL ingress_no_404_retry" grep -q '^FAIL ingress_no_404_retry rayd-jobs:' "$T/k8s-bad.out"
sed 's/"--appendonly", "yes"/"--appendonly", "no"/' "$RAYD_ROOT/docker/compose.yml" >"$T/compose-bad.yml"
sed 's/proxy_next_upstream error timeout http_503 non_idempotent;/proxy_next_upstream error timeout http_404;/' \
    "$RAYD_ROOT/docker/nginx.conf" >"$T/nginx-bad.conf"
node "$K8S/compose.mjs" "$T/compose-bad.yml" "$T/nginx-bad.conf" >"$T/compose-bad.out" 2>&1
check compose_refuses_aof_off "no FAIL compose_redis_aof_on" grep -q '^FAIL compose_redis_aof_on:' "$T/compose-bad.out"
check compose_refuses_404_retry "no FAIL nginx_no_404_retry" grep -q '^FAIL nginx_no_404_retry:' "$T/compose-bad.out"
sed 's/condition: service_healthy/condition: healthy/' "$RAYD_ROOT/docker/compose.yml" >"$T/compose-typo.yml"
node "$K8S/compose.mjs" "$T/compose-typo.yml" "$RAYD_ROOT/docker/nginx.conf" >"$T/compose-typo.out" 2>&1
check compose_schema_refuses_typo "no FAIL compose_schema: $(head -c 300 "$T/compose-typo.out")" \
    grep -q '^FAIL compose_schema:.*depends_on' "$T/compose-typo.out"
exit $((NFAIL > 0))
