// validate.mjs -- docker/k8s/ checked offline, without a cluster.
//
//   node tests/k8s/validate.mjs DIR...        (tests/integration/k8s_manifests.sh)
//
// Every YAML document of every *.yaml under DIR is validated against the
// JSON schema of its apiVersion and kind: the Kubernetes API's own OpenAPI
// schemas as compiled by kubernetes-models, and the prometheus-operator
// CRDs' for the PodMonitor (both from npm, pinned in package-lock.json).
// That catches wrong types, missing required fields and bad enum values; it
// does not catch unknown fields (the schemas allow them), so the rules this
// project relies on are checked by name below: pinned images, no scrape
// annotations that would get 401, the token Secret shared by the pods and
// the PodMonitor, selectors that select the pods, Ingresses that retry 503
// but never 404 (every pod answers for every job), probes that keep busy
// pods in rotation, and the Redis the pods share: a StatefulSet with a
// volume claim, AOF on, noeviction, its password from the Secret the pods
// read into RAYD_REDIS_PASSWORD, and a Service that --redis names.
// Prints "PASS name" / "FAIL name: why" lines; exit status 1 on a FAIL.
// --expect-invalid FILE: passes only when FILE is refused (the self-test).
import { readFileSync, readdirSync, statSync } from "node:fs";
import { join, relative } from "node:path";
import { parseAllDocuments } from "yaml";

let failed = 0;
const pass = (name) => console.log(`PASS ${name}`);
const fail = (name, why) => {
  console.log(`FAIL ${name}: ${why}`);
  failed++;
};
const check = (name, ok, why) => (ok ? pass(name) : fail(name, why));

// the module of the model class of apiVersion + kind
function modelPath(apiVersion, kind) {
  if (apiVersion.startsWith("monitoring.coreos.com/"))
    return `@kubernetes-models/prometheus-operator/${apiVersion}/${kind}`;
  return `kubernetes-models/${apiVersion}/${kind}`; // core "v1" too: kubernetes-models/v1/Service
}

// the schema errors of one document, or null
async function schemaErrors(doc) {
  if (!doc || typeof doc !== "object") return "not a mapping";
  if (typeof doc.apiVersion !== "string" || typeof doc.kind !== "string")
    return "no apiVersion or kind";
  let mod;
  try {
    mod = await import(modelPath(doc.apiVersion, doc.kind));
  } catch {
    return `no schema for ${doc.apiVersion} ${doc.kind}`;
  }
  const Model = mod[doc.kind] || mod.default;
  try {
    new Model(doc).validate();
    return null;
  } catch (e) {
    return String(e.message || e).slice(0, 400);
  }
}

function yamlFiles(dir) {
  const out = [];
  for (const e of readdirSync(dir).sort()) {
    const p = join(dir, e);
    if (statSync(p).isDirectory()) out.push(...yamlFiles(p));
    else if (/\.ya?ml$/.test(e)) out.push(p);
  }
  return out;
}

function loadDocs(file) {
  const docs = [];
  for (const d of parseAllDocuments(readFileSync(file, "utf8"))) {
    if (d.errors.length) throw new Error(d.errors[0].message);
    const v = d.toJS();
    if (v !== null) docs.push(v);
  }
  return docs;
}

const args = process.argv.slice(2);
if (args[0] === "--expect-invalid") {
  let why = null;
  try {
    for (const doc of loadDocs(args[1])) why = why || (await schemaErrors(doc));
  } catch (e) {
    why = e.message;
  }
  check("schema_rejects_bad_manifest", why !== null, `${args[1]} was accepted`);
  if (why) console.log(`# refused as it should be: ${why.split("\n")[0]}`);
  process.exit(failed ? 1 : 0);
}

const all = []; // {file, doc}
for (const dir of args) {
  for (const file of yamlFiles(dir)) {
    const name = relative(process.cwd(), file);
    let docs;
    try {
      docs = loadDocs(file);
    } catch (e) {
      fail(`yaml ${name}`, e.message);
      continue;
    }
    for (const doc of docs) {
      const why = await schemaErrors(doc);
      check(`schema ${name} ${doc?.kind}/${doc?.metadata?.name}`, !why, why);
      all.push({ file: name, doc });
    }
  }
}

const of = (kind) => all.filter((x) => x.doc.kind === kind).map((x) => x.doc);
const deploy = of("Deployment")[0];
const redis = of("StatefulSet").find((x) => x.metadata.name === "rayd-redis");
const services = of("Service");
const ingresses = of("Ingress");
const hpa = of("HorizontalPodAutoscaler")[0];
const podmon = of("PodMonitor")[0];
const pdb = of("PodDisruptionBudget")[0];
const matches = (sel, labels) =>
  !!sel && Object.entries(sel).every(([k, v]) => labels && labels[k] === v);

check("rules_have_every_kind", deploy && services.length && ingresses.length && hpa && podmon && pdb,
  "missing one of Deployment, Service, Ingress, HorizontalPodAutoscaler, PodMonitor, PodDisruptionBudget");
if (!deploy) process.exit(1);
const tmpl = deploy.spec.template;
const podLabels = tmpl.metadata.labels;
const containers = tmpl.spec.containers;

for (const c of containers) {
  const tag = /:([^:/@]+)$/.exec(c.image || "");
  check(`image_pinned ${c.name}`, !!tag && tag[1] !== "latest",
    `image ${c.image}: a version tag, not latest or none`);
  check(`image_pull_policy ${c.name}`, c.imagePullPolicy === "IfNotPresent",
    `imagePullPolicy ${c.imagePullPolicy}: IfNotPresent for a pinned tag`);
  check(`readiness_keeps_busy_pods ${c.name}`, c.readinessProbe?.httpGet?.path === "/healthz",
    `readiness on ${c.readinessProbe?.httpGet?.path}: /readyz takes a busy pod (and its jobs) out of the endpoints`);
}
const annos = { ...(tmpl.metadata.annotations || {}), ...(deploy.metadata.annotations || {}) };
check("no_prometheus_annotations", !Object.keys(annos).some((k) => k.startsWith("prometheus.io/")),
  "prometheus.io/* annotations: /metrics needs the token, annotations carry none");

const tokenEnv = containers.flatMap((c) => c.env || []).find((e) => e.name === "RAYD_TOKEN_FILE");
const secretVol = (tmpl.spec.volumes || []).find((v) => v.secret);
check("pods_use_token", tokenEnv && secretVol, "no RAYD_TOKEN_FILE or no Secret volume");
const auth = podmon?.spec?.podMetricsEndpoints?.[0]?.authorization;
check("podmonitor_scrapes_with_token",
  auth && (auth.type || "Bearer") === "Bearer" && auth.credentials?.name === secretVol?.secret?.secretName &&
    auth.credentials?.key === "token",
  `authorization ${JSON.stringify(auth)} against the pods' Secret ${secretVol?.secret?.secretName}`);
check("podmonitor_selects_pods", matches(podmon?.spec?.selector?.matchLabels, podLabels),
  "the PodMonitor's selector does not match the pod labels");
const portNames = containers.flatMap((c) => (c.ports || []).map((p) => p.name));
check("podmonitor_port", portNames.includes(podmon?.spec?.podMetricsEndpoints?.[0]?.port),
  "the PodMonitor's port is not a named port of the pods");

const redisLabels = redis?.spec?.template?.metadata?.labels;
for (const s of services)
  check(`service_selects_pods ${s.metadata.name}`,
    matches(s.spec.selector, podLabels) || matches(s.spec.selector, redisLabels),
    "the Service's selector matches neither the rayd pods nor the Redis pod");
check("deployment_selector", matches(deploy.spec.selector.matchLabels, podLabels),
  "the Deployment's selector does not match its template");
check("pdb_selects_pods", matches(pdb?.spec?.selector?.matchLabels, podLabels), "the PDB selects no pod");
check("hpa_targets_deployment",
  hpa?.spec?.scaleTargetRef?.kind === "Deployment" && hpa.spec.scaleTargetRef.name === deploy.metadata.name,
  "the HPA scales something else");

const A = "nginx.ingress.kubernetes.io/";
let jobsRouted = false;
for (const ing of ingresses) {
  const a = ing.metadata.annotations || {};
  const n = ing.metadata.name;
  for (const rule of ing.spec.rules || [])
    for (const p of rule.http?.paths || []) {
      const svc = services.find((s) => s.metadata.name === p.backend.service?.name);
      check(`ingress_backend ${n} ${p.path}`,
        svc && svc.spec.ports.some((sp) => sp.name === p.backend.service.port.name || sp.port === p.backend.service.port.number),
        `backend ${JSON.stringify(p.backend)} is no Service port`);
      if (p.path === "/v1/jobs") {
        jobsRouted = true;
        check("jobs_sse_unbuffered", a[A + "proxy-buffering"] === "off", `${n}: proxy-buffering not off`);
      }
    }
  const next = (a[A + "proxy-next-upstream"] || "").split(/\s+/);
  check(`ingress_retries_503 ${n}`, next.includes("http_503"), `${n}: no retry on 503`);
  check(`ingress_no_404_retry ${n}`, !next.includes("http_404"),
    `${n}: proxy-next-upstream retries http_404, but every pod answers for every job (Redis)`);
  check(`ingress_ewma ${n}`, a[A + "load-balance"] === "ewma",
    `${n}: load-balance ${a[A + "load-balance"]} (ewma skips the pods already tried)`);
  check(`ingress_tries_cover_pods ${n}`, Number(a[A + "proxy-next-upstream-tries"]) >= (hpa?.spec?.maxReplicas || 0),
    `${n}: proxy-next-upstream-tries ${a[A + "proxy-next-upstream-tries"]} < maxReplicas ${hpa?.spec?.maxReplicas}`);
}
check("jobs_ingress", jobsRouted, "no Ingress path /v1/jobs");

// --- the Redis the pods share --------------------------------------------
// flag(args, name): the word after name in a container's args, or undefined
const flag = (args, name) => {
  const i = (args || []).indexOf(name);
  return i < 0 ? undefined : args[i + 1];
};
check("redis_statefulset", !!redis, "no StatefulSet rayd-redis");
if (!redis) process.exit(1);
const rc = redis.spec.template.spec.containers.find((c) => c.name === "redis");
const rargs = [...(rc?.command || []), ...(rc?.args || [])];
const rtag = /:([^:/@]+)$/.exec(rc?.image || "");
check("redis_image_pinned", !!rtag && rtag[1] !== "latest", `image ${rc?.image}: a version tag`);
check("redis_aof_on", flag(rargs, "--appendonly") === "yes",
  `--appendonly is ${flag(rargs, "--appendonly")}: a restarted Redis would forget the jobs`);
check("redis_noeviction", flag(rargs, "--maxmemory-policy") === "noeviction",
  `--maxmemory-policy ${flag(rargs, "--maxmemory-policy")}: an eviction policy drops jobs' keys`);
const claims = (redis.spec.volumeClaimTemplates || []).map((v) => v.metadata.name);
const dataDir = flag(rargs, "--dir") || "/data";
const dataMount = (rc?.volumeMounts || []).find((m) => m.mountPath === dataDir);
check("redis_aof_on_claim", !!dataMount && claims.includes(dataMount.name),
  `${dataDir} (the AOF's folder) is not a volumeClaimTemplate's volume: the pod's restart loses it`);
const renv = Object.fromEntries((rc?.env || []).map((e) => [e.name, e]));
const pwArg = flag(rargs, "--requirepass") || "";
const pwVar = /^\$\(([A-Z_]+)\)$/.exec(pwArg)?.[1];
const rSecret = renv[pwVar]?.valueFrom?.secretKeyRef;
check("redis_password_from_secret", !!rSecret, `--requirepass "${pwArg}" is not an env from a Secret`);
check("redis_ready_on_pong", JSON.stringify(rc?.readinessProbe?.exec?.command || []).includes("PONG"),
  "readiness is not PING answered PONG (a Redis replaying its AOF says LOADING)");
const redisSvc = services.find((s) => matches(s.spec.selector, redisLabels));
check("redis_service", !!redisSvc && redisSvc.metadata.name === redis.spec.serviceName,
  `no Service ${redis.spec.serviceName} (the StatefulSet's serviceName) selecting the Redis pod`);
for (const c of containers) {
  const url = flag(c.args || c.command, "--redis") || "";
  const u = /^redis:\/\/([^:/@]+)(?::(\d+))?/.exec(url);
  check(`rayd_uses_redis ${c.name}`,
    !!u && u[1] === redisSvc?.metadata?.name &&
      redisSvc.spec.ports.some((p) => p.port === Number(u[2] || 6379)),
    `--redis "${url}": not redis://SERVICE:PORT of the Redis Service ${redisSvc?.metadata?.name}`);
  check(`rayd_redis_password_secret ${c.name}`, !url.includes("@"), "the password is in the URL (ps shows it)");
  const pw = (c.env || []).find((e) => e.name === "RAYD_REDIS_PASSWORD")?.valueFrom?.secretKeyRef;
  check(`rayd_redis_password ${c.name}`, !!pw && pw.name === rSecret?.name && pw.key === rSecret?.key,
    `RAYD_REDIS_PASSWORD ${JSON.stringify(pw)} is not the Redis's Secret ${JSON.stringify(rSecret)}`);
  check(`rayd_no_data_dir ${c.name}`,
    flag(c.args, "--data-dir") === undefined && !(c.env || []).some((e) => e.name === "RAYD_DATA_DIR"),
    "--data-dir with --redis: rayd refuses to start (choose one: both keep jobs)");
}

process.exit(failed ? 1 : 0);
