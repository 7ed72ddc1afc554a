// compose.mjs -- docker/compose.yml and docker/nginx.conf checked offline.
//
//   node tests/k8s/compose.mjs [COMPOSE [NGINX_CONF]]   (tests/integration/k8s_manifests.sh)
//
// The tests cannot run Docker (nor `docker compose config`), so the file is
// validated against the Compose Specification's JSON schema
// (compose-spec.json: schema/compose-spec.json of
// github.com/compose-spec/compose-spec at commit 170098b, June 2026;
// Apache-2.0, Copyright 2020 The Compose Specification Authors) with ajv,
// and the rules the compose file relies on are checked by name on the parsed
// YAML (the same pinned "yaml" package as validate.mjs): a Redis with the append-only file
// on a named volume and noeviction, not published; at least three rayd nodes
// from one pinned image, every one started with --redis naming that Redis
// service and waiting for it to be healthy, none with --data-dir; nginx's
// upstream lists exactly those nodes; and nginx.conf retries 503 but never
// 404 (every node answers for every job).  Prints "PASS name" / "FAIL name:
// why" lines; exit status 1 on a FAIL.
import Ajv from "ajv";
import { readFileSync } from "node:fs";
import { parse } from "yaml";

const composeFile = process.argv[2] || "docker/compose.yml";
const nginxFile = process.argv[3] || "docker/nginx.conf";
let failed = 0;
const check = (name, ok, why) => {
  if (ok) console.log(`PASS ${name}`);
  else {
    console.log(`FAIL ${name}: ${why}`);
    failed++;
  }
};

let doc;
try {
  doc = parse(readFileSync(composeFile, "utf8"), { merge: true });
} catch (e) {
  check("compose_yaml", false, `${composeFile}: ${e.message}`);
  process.exit(1);
}
// the schema says draft-07 by an https URL ajv does not know by that name
const schema = JSON.parse(readFileSync(new URL("./compose-spec.json", import.meta.url), "utf8"));
delete schema.$schema;
const validate = new Ajv({ allErrors: true, strict: false }).compile(schema);
check("compose_schema", validate(doc),
  (validate.errors || []).slice(0, 3).map((e) => `${e.instancePath || "/"} ${e.message}`).join("; "));

const services = doc?.services || {};
// the word after name in a command list, or undefined
const flag = (cmd, name) => {
  const words = Array.isArray(cmd) ? cmd : String(cmd || "").split(/\s+/);
  const i = words.indexOf(name);
  return i < 0 ? undefined : words[i + 1];
};
const pinned = (image) => {
  const tag = /:([^:/@]+)$/.exec(image || "");
  return !!tag && tag[1] !== "latest";
};

// --- Redis -----------------------------------------------------------------
const redisName = Object.keys(services).find((n) => /(^|\/)redis:/.test(services[n].image || ""));
const redis = services[redisName];
check("compose_redis_service", !!redis, "no service with a redis image");
if (!redis) process.exit(1);
const rcmd = redis.command;
check("compose_redis_pinned", pinned(redis.image), `image ${redis.image}: a version tag, not latest`);
check("compose_redis_aof_on", flag(rcmd, "--appendonly") === "yes",
  `--appendonly is ${flag(rcmd, "--appendonly")}: a restarted Redis would forget the jobs`);
check("compose_redis_noeviction", flag(rcmd, "--maxmemory-policy") === "noeviction",
  `--maxmemory-policy ${flag(rcmd, "--maxmemory-policy")}: an eviction policy drops jobs' keys`);
const dir = flag(rcmd, "--dir") || "/data";
const vol = (redis.volumes || []).map((v) => String(v).split(":")).find((v) => v[1] === dir);
check("compose_redis_volume", !!vol && Object.keys(doc.volumes || {}).includes(vol[0]),
  `${dir} (the AOF's folder) is not a named volume: recreating the container loses the jobs`);
check("compose_redis_not_published", !redis.ports, `ports ${JSON.stringify(redis.ports)}: keep Redis inside`);
check("compose_redis_healthcheck", JSON.stringify(redis.healthcheck?.test || "").includes("PONG"),
  "no healthcheck waiting for PONG (a Redis replaying its AOF says LOADING)");

// --- the rayd nodes ---------------------------------------------------------
const nodes = Object.keys(services).filter((n) => /(^|\/)rayd:/.test(services[n].image || ""));
check("compose_three_nodes", nodes.length >= 3, `${nodes.length} rayd services`);
for (const n of nodes) {
  const s = services[n];
  const url = flag(s.command, "--redis") || "";
  const u = /^redis:\/\/([^:/@]+)(?::(\d+))?/.exec(url);
  check(`compose_node_redis ${n}`, !!u && u[1] === redisName && Number(u[2] || 6379) === 6379,
    `--redis "${url}": not redis://${redisName}:6379`);
  check(`compose_node_waits_redis ${n}`, s.depends_on?.[redisName]?.condition === "service_healthy",
    `depends_on ${JSON.stringify(s.depends_on)}: start once Redis answers`);
  check(`compose_node_pinned ${n}`, pinned(s.image), `image ${s.image}`);
  check(`compose_node_no_data_dir ${n}`,
    flag(s.command, "--data-dir") === undefined && !("RAYD_DATA_DIR" in (s.environment || {})),
    "--data-dir with --redis: rayd refuses to start (choose one: both keep jobs)");
}

// --- nginx: its upstream is those nodes, and no 404 retry -------------------
let conf = "";
try {
  conf = readFileSync(nginxFile, "utf8");
} catch (e) {
  check("nginx_conf_read", false, e.message);
}
const code = conf.replace(/#.*$/gm, "");
const upstream = [...conf.matchAll(/^\s*server\s+([^:\s;]+):8080[^\n]*# @node/gm)].map((m) => m[1]);
check("compose_nginx_upstream", upstream.sort().join(" ") === [...nodes].sort().join(" "),
  `nginx.conf's upstream "${upstream.join(" ")}" against the compose nodes "${nodes.join(" ")}"`);
const nexts = [...code.matchAll(/proxy_next_upstream\s+([^;]*);/g)].map((m) => m[1].split(/\s+/));
check("nginx_no_404_retry", nexts.length > 0 && !nexts.some((w) => w.includes("http_404")),
  "a proxy_next_upstream retries http_404, but every node answers for every job (Redis)");
check("nginx_retries_503", nexts.length > 0 && nexts.every((w) => w.includes("http_503")),
  `every proxy_next_upstream must retry http_503: ${nexts.map((w) => w.join(" ")).join(" | ")}`);

process.exit(failed ? 1 : 0);
