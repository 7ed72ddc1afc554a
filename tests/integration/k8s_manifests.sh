#!/usr/bin/env bash
# k8s_manifests.sh -- docker/k8s/ validated offline (no cluster, no network).
#
# tests/k8s/validate.mjs checks every document against the Kubernetes and
# prometheus-operator schemas (kubernetes-models from npm, pinned in
# tests/k8s/package-lock.json and installed by `make test` like the browser
# tests' packages) and the rules the deployment relies on (pinned image,
# token for Prometheus, jobs routed by 404 retries, ...).  A manifest with a
# wrong type must be refused, so the validator is shown able to fail.  When
# node or the packages cannot be had (no npm, no registry), the test says
# SKIP and passes nothing.
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
exit $((NFAIL > 0))
