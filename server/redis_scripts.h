// The Lua scripts that change a job's state in Redis. Each runs atomically,
// so a job's hash, its entry in the job stream and its event stream never
// disagree, however many servers and workers call at once.
//
// Keys (prefix "vpremesh:"):
//   jobs:<priority>  stream per priority (-10..10), consumer group "workers";
//                    one entry {job: ID} per waiting or running job; a
//                    delivered entry stays pending until the job ends.
//   job:<ID>         hash: spec, peer (the client --max-jobs-per-client counts:
//                    a tenant, or an address without port), tenant (the
//                    owner; "" without --auth-tokens), label, prio, state (JobState number),
//                    worker, stage, submitted_ms, finished_ms, cancel (a
//                    Failure), deliveries, token, stream, entry, ttl_ms,
//                    nevents.
//   events:<ID>      stream of serialized JobEvents; event N has the entry id
//                    0-(N+1), so Watch from sequence N is one XRANGE.
//   upload:<ID>      the Draco upload, with --upload-ttl (RedisBlobStore; the
//                    scripts delete it when the job ends).
//   clients          hash: peer -> unfinished jobs (--max-jobs-per-client),
//                    shared by every replica.
//   finished         hash: state -> jobs ended so far (metrics).
//   dead             the dead-letter stream: {job, reason, deliveries, worker}.
//   doorbell         a short stream with an entry per submission: idle workers
//                    block on it (XREAD) instead of polling.
//   wake:<random>    one per server process: subscribe() writes to it to wake
//                    the process's blocking XREAD over watched event streams.
//   workers          sorted set: consumer (one worker thread) -> expiry in
//                    Redis time (ms); renewed with every heartbeat period.
//   workers:busy     the same for the consumers running a job now.
//
// `token` is the job's delivery number. Every write by a worker carries the
// token it claimed with and is refused once another worker has reclaimed the
// job, so a job run twice (at-least-once delivery) records one answer.
#pragma once

namespace vpr::service::lua {

// Shared by the scripts below (prepended to each).
inline constexpr const char* kCommon = R"lua(
local function append(job, events, bytes)
  local n = redis.call('HINCRBY', job, 'nevents', 1)
  redis.call('XADD', events, '0-' .. n, 'e', bytes)
end
-- Redis's clock in ms: every host's expiries compare against one clock.
local function redis_ms()
  local t = redis.call('TIME')
  return tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
end
local function waiting(stream, group)
  return redis.call('XLEN', stream) - redis.call('XPENDING', stream, group)[1]
end
-- Ends a job: state, expiry of its keys, its stream entry acknowledged and
-- deleted, its client's count and the finished counter.
local function close(job, events, upload, clients, finished, state, now, group, f_stream, f_entry, f_peer, f_ttl)
  redis.call('HSET', job, 'state', state, 'finished_ms', now, 'stage', '')
  redis.call('PEXPIRE', job, f_ttl)
  redis.call('PEXPIRE', events, f_ttl)
  redis.call('DEL', upload)
  if f_stream and f_entry then
    redis.call('XACK', f_stream, group, f_entry)
    redis.call('XDEL', f_stream, f_entry)
  end
  if f_peer then
    if redis.call('HINCRBY', clients, f_peer, -1) <= 0 then redis.call('HDEL', clients, f_peer) end
  end
  redis.call('HINCRBY', finished, state, 1)
end
)lua";

// KEYS: job, upload, events, clients, the job's stream, doorbell, then every
//       job stream.
// ARGV: id, spec, peer, label, priority, now_ms, max_queue,
//       the client's job limit, queued event, result_ttl_ms, group, tenant.
// The upload is already in the BlobStore (server/blob_store.h).
// Returns {1, waiting}, {0, waiting} (queue full), {-1, unfinished} (client
// full) or {-2, 0} (id taken).
inline constexpr const char* kSubmit = R"lua(
local w = 0
for i = 7, #KEYS do w = w + waiting(KEYS[i], ARGV[11]) end
if w >= tonumber(ARGV[7]) then return {0, w} end
local mine = tonumber(redis.call('HGET', KEYS[4], ARGV[3]) or '0')
if mine >= tonumber(ARGV[8]) then return {-1, mine} end
if redis.call('EXISTS', KEYS[1]) == 1 then return {-2, 0} end
redis.call('HSET', KEYS[1], 'spec', ARGV[2], 'peer', ARGV[3], 'tenant', ARGV[12], 'label', ARGV[4], 'prio', ARGV[5], 'state', 1,
           'submitted_ms', ARGV[6], 'ttl_ms', ARGV[10], 'deliveries', 0, 'token', 0, 'nevents', 0, 'stream', KEYS[5])
append(KEYS[1], KEYS[3], ARGV[9])
redis.call('HSET', KEYS[1], 'entry', redis.call('XADD', KEYS[5], '*', 'job', ARGV[1]))
redis.call('HINCRBY', KEYS[4], ARGV[3], 1)
redis.call('XADD', KEYS[6], 'MAXLEN', '~', 100, '*', 'job', ARGV[1])
return {1, w}
)lua";

// KEYS: doorbell, then the job streams, highest priority first.
// ARGV: group, consumer, visibility_ms, max_deliveries, key prefix, worker.
// Reclaims an entry idle past the visibility timeout (its worker died) before
// reading a new one. Returns {'none', doorbell's last id} (nothing to do: the
// caller blocks on the doorbell from that id, so a job submitted right after
// this script still wakes it), {'job', id, token, spec, submitted_ms} or
// {'dead', id, token, deliveries}: the caller fails the latter to the
// dead-letter stream (the failure message is built in C++).
inline constexpr const char* kClaim = R"lua(
local function take(stream, entry)
  local id = entry[2][2]
  local job = ARGV[5] .. 'job:' .. id
  local state = tonumber(redis.call('HGET', job, 'state') or '0')
  if state == 0 or state >= 3 then
    redis.call('XACK', stream, ARGV[1], entry[1])
    redis.call('XDEL', stream, entry[1])
    return nil
  end
  local d = redis.call('HINCRBY', job, 'deliveries', 1)
  redis.call('HSET', job, 'token', d, 'stream', stream, 'entry', entry[1])
  if d > tonumber(ARGV[4]) then
    redis.call('HINCRBY', job, 'deliveries', -1)  -- not run again: 'deliveries' counts the runs
    return {'dead', id, tostring(d), tostring(d - 1)}
  end
  redis.call('HSET', job, 'state', 2, 'worker', ARGV[6], 'stage', 'starting')
  local f = redis.call('HMGET', job, 'spec', 'submitted_ms')
  return {'job', id, tostring(d), f[1], f[2]}
end
local function none()
  local last = redis.call('XREVRANGE', KEYS[1], '+', '-', 'COUNT', 1)[1]
  return {'none', last and last[1] or '0-0'}
end
for round = 1, 32 do
  local seen = false
  for i = 2, #KEYS do
    local r = redis.call('XAUTOCLAIM', KEYS[i], ARGV[1], ARGV[2], ARGV[3], '0-0', 'COUNT', 1)
    for _, entry in ipairs(r[2]) do
      seen = true
      local t = take(KEYS[i], entry)
      if t then return t end
    end
  end
  for i = 2, #KEYS do
    local r = redis.call('XREADGROUP', 'GROUP', ARGV[1], ARGV[2], 'COUNT', 1, 'STREAMS', KEYS[i], '>')
    if r then
      seen = true
      local t = take(KEYS[i], r[1][2][1])
      if t then return t end
    end
  end
  if not seen then return none() end
end
return none()
)lua";

// KEYS: job, events. ARGV: token, stage name ('' for none), events...
// Returns 1, or 0 when the caller no longer owns the running job.
inline constexpr const char* kPublish = R"lua(
local f = redis.call('HMGET', KEYS[1], 'token', 'state')
if f[1] ~= ARGV[1] or f[2] ~= '2' then return 0 end
for i = 3, #ARGV do append(KEYS[1], KEYS[2], ARGV[i]) end
if ARGV[2] ~= '' then redis.call('HSET', KEYS[1], 'stage', ARGV[2]) end
return 1
)lua";

// KEYS: job, events, upload, clients, finished, dead.
// ARGV: token, final state, now_ms, group, dead-letter reason ('' for none),
//       job id, worker, events...
// Returns 1, or 0 when the caller does not own the job (any more): a
// re-delivered job's first run cannot add a second answer.
inline constexpr const char* kFinish = R"lua(
local f = redis.call('HMGET', KEYS[1], 'token', 'state', 'stream', 'entry', 'peer', 'ttl_ms', 'deliveries')
if f[1] ~= ARGV[1] or (f[2] ~= '1' and f[2] ~= '2') then return 0 end
for i = 8, #ARGV do append(KEYS[1], KEYS[2], ARGV[i]) end
close(KEYS[1], KEYS[2], KEYS[3], KEYS[4], KEYS[5], ARGV[2], ARGV[3], ARGV[4], f[3], f[4], f[5], f[6])
if ARGV[5] ~= '' then
  redis.call('XADD', KEYS[6], '*', 'job', ARGV[6], 'reason', ARGV[5], 'deliveries', f[7],
             'worker', ARGV[7])
end
return 1
)lua";

// KEYS: job, events, upload, clients, finished.
// ARGV: cancel Failure, cancelled event, now_ms, group.
// A queued job ends now; a running one gets `cancel` set, which its worker
// reads at the next stage boundary. Returns the state after the request, or
// -1 when the job is unknown.
inline constexpr const char* kCancel = R"lua(
local f = redis.call('HMGET', KEYS[1], 'state', 'cancel', 'stream', 'entry', 'peer', 'ttl_ms')
if not f[1] then return -1 end
if f[1] == '1' then
  append(KEYS[1], KEYS[2], ARGV[2])
  close(KEYS[1], KEYS[2], KEYS[3], KEYS[4], KEYS[5], 5, ARGV[3], ARGV[4], f[3], f[4], f[5], f[6])
  return 5
end
if f[1] == '2' and (not f[2] or f[2] == '') then redis.call('HSET', KEYS[1], 'cancel', ARGV[1]) end
return tonumber(f[1])
)lua";

// KEYS: job. ARGV: token, group, consumer.
// Resets the idle time of the job's pending entry, so no other worker
// reclaims it while this one works. Returns 0 once the job is not ours.
inline constexpr const char* kHeartbeat = R"lua(
local f = redis.call('HMGET', KEYS[1], 'token', 'state', 'stream', 'entry')
if f[1] ~= ARGV[1] or f[2] ~= '2' then return 0 end
redis.call('XCLAIM', f[3], ARGV[2], ARGV[3], 0, f[4], 'JUSTID')
return 1
)lua";

// KEYS: the worker registry, its busy subset (sorted sets: consumer ->
// expiry in Redis ms), then every job stream. ARGV: time to live (ms), group,
// then (consumer, busy 0|1) pairs of this process.
// Renews this process's consumers, then removes consumers whose process
// stopped renewing (killed) from the group, once they own no entry: deleting
// a consumer drops its pending entries, which must wait to be reclaimed.
// Returns how many consumers it removed.
inline constexpr const char* kAlive = R"lua(
local now = redis_ms()
local expiry = now + tonumber(ARGV[1])
for i = 3, #ARGV, 2 do
  redis.call('ZADD', KEYS[1], expiry, ARGV[i])
  if ARGV[i + 1] == '1' then redis.call('ZADD', KEYS[2], expiry, ARGV[i]) else redis.call('ZREM', KEYS[2], ARGV[i]) end
end
local removed = 0
for _, c in ipairs(redis.call('ZRANGEBYSCORE', KEYS[1], '-inf', now)) do
  local owns = 0
  for s = 3, #KEYS do owns = owns + #redis.call('XPENDING', KEYS[s], ARGV[2], '-', '+', 1, c) end
  if owns == 0 then
    for s = 3, #KEYS do redis.call('XGROUP', 'DELCONSUMER', KEYS[s], ARGV[2], c) end
    redis.call('ZREM', KEYS[1], c)
    redis.call('ZREM', KEYS[2], c)
    removed = removed + 1
  end
end
return removed
)lua";

// KEYS: the worker registry and its busy subset. Returns {live, busy}:
// worker threads on any host that renewed within their time to live.
inline constexpr const char* kFleet = R"lua(
local now = redis_ms()
return {redis.call('ZCOUNT', KEYS[1], now, '+inf'), redis.call('ZCOUNT', KEYS[2], now, '+inf')}
)lua";

// KEYS: job hashes. Returns each job's event count (0 for a job gone).
inline constexpr const char* kEventCounts = R"lua(
local n = {}
for i = 1, #KEYS do n[i] = tonumber(redis.call('HGET', KEYS[i], 'nevents') or '0') end
return n
)lua";

// KEYS: job streams to count. ARGV: group.
// Returns {waiting, pending (running or awaiting reclaim)}.
inline constexpr const char* kCount = R"lua(
local w, p = 0, 0
for i = 1, #KEYS do
  local n = redis.call('XPENDING', KEYS[i], ARGV[1])[1]
  w = w + redis.call('XLEN', KEYS[i]) - n
  p = p + n
end
return {w, p}
)lua";

// KEYS: the job's stream, then every stream of higher priority.
// ARGV: group, the job's entry id. Returns how many jobs run before it.
inline constexpr const char* kPosition = R"lua(
local ahead = 0
for i = 2, #KEYS do ahead = ahead + waiting(KEYS[i], ARGV[1]) end
local last = '0-0'
for _, g in ipairs(redis.call('XINFO', 'GROUPS', KEYS[1])) do
  local name, delivered
  for j = 1, #g, 2 do
    if g[j] == 'name' then name = g[j + 1] elseif g[j] == 'last-delivered-id' then delivered = g[j + 1] end
  end
  if name == ARGV[1] then last = delivered end
end
return ahead + #redis.call('XRANGE', KEYS[1], '(' .. last, '(' .. ARGV[2], 'COUNT', 100000)
)lua";

}  // namespace vpr::service::lua
