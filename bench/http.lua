-- bench/http.lua -- wrk script for bench/http.sh: POSTs one scene to
-- /v1/render, the whole image or, with a tile size, a random tile of it.
--
--   wrk -s bench/http.lua URL -- SCENE.json [TILE WIDTH HEIGHT [any]]
--
-- Tiles are on the TILE grid (what a tile client asks for: identical ones in
-- flight are rendered once), or with `any` at any pixel offset, so nearly
-- every request is a distinct render.
-- Every answer is counted by status; a 503 must carry Retry-After (those
-- without are counted as bad503).  done() prints one line of key=value
-- figures that bench/http.sh parses: requests, rps (all answers), ok_rps
-- (200s), p50_ms, p90_ms, p99_ms, max_ms (of all answers),
-- status counts, bad503, and wrk's socket errors.
local threads = {}
local body, tile, width, height, anywhere

function setup(thread)
  table.insert(threads, thread)
end

function init(args)
  local f = assert(io.open(args[1], "rb"))
  body = f:read("*a")
  f:close()
  tile = tonumber(args[2] or "0")
  width = tonumber(args[3] or "0")
  height = tonumber(args[4] or "0")
  anywhere = args[5] == "any"
  math.randomseed(os.time() + math.floor(os.clock() * 1e6))
  wrk.method = "POST"
  wrk.body = body
  wrk.headers["Content-Type"] = "application/json"
  counts = {}
  bad503 = 0
end

function request()
  local path = "/v1/render"
  if tile > 0 then
    local x, y
    if anywhere then
      x, y = math.random(0, width - tile), math.random(0, height - tile)
    else
      local nx, ny = math.floor(width / tile), math.floor(height / tile)
      x, y = math.random(0, nx - 1) * tile, math.random(0, ny - 1) * tile
    end
    path = string.format("/v1/render?x=%d&y=%d&w=%d&h=%d", x, y, tile, tile)
  end
  return wrk.format(nil, path)
end

function response(status, headers, b)
  counts[status] = (counts[status] or 0) + 1
  if status == 503 and not headers["Retry-After"] then
    bad503 = bad503 + 1
  end
end

function done(summary, latency, requests)
  local total, b503 = {}, 0
  for _, t in ipairs(threads) do
    local c = t:get("counts")
    for k, v in pairs(c) do total[k] = (total[k] or 0) + v end
    b503 = b503 + t:get("bad503")
  end
  local st = {}
  for k, v in pairs(total) do table.insert(st, string.format("s%d=%d", k, v)) end
  table.sort(st)
  local e = summary.errors
  io.write(string.format(
    "RESULT requests=%d rps=%.1f ok_rps=%.1f p50_ms=%.2f p90_ms=%.2f p99_ms=%.2f max_ms=%.2f %s bad503=%d " ..
    "connect_err=%d read_err=%d write_err=%d timeout_err=%d\n",
    summary.requests, summary.requests / (summary.duration / 1e6),
    (total[200] or 0) / (summary.duration / 1e6),
    latency:percentile(50) / 1000, latency:percentile(90) / 1000, latency:percentile(99) / 1000,
    latency.max / 1000, table.concat(st, " "), b503,
    e.connect, e.read, e.write, e.timeout))
end
