//! Timestamp-query profiler: named scopes around GPU passes, read back after the frame's fence.
//!
//! Invariants:
//! - One query pool per frame slot, reset from the host (`hostQueryReset`) when the slot is reused; a slot's
//!   results are read in [`Profiler::collect`], which the caller invokes only after that slot's fence has
//!   signalled (so no wait is needed and nothing stalls the GPU).
//! - Ticks are masked by `timestampValidBits` before subtracting and scaled by `timestampPeriod` (ns/tick).
//! - Where the queue has no timestamps (`timestampValidBits == 0`) every call is a no-op and the outputs
//!   are empty: profiling never changes what the engine does.
//! - On lavapipe the timestamps measure the CPU driver's execution time, not a GPU's. Passes that run as
//!   native code on the host ([`Profiler::record_host`]) join the statistics, not the trace.
//! - Memory is bounded however long the run (a 10,000-frame demo must keep a flat resident size): per pass,
//!   calls, min, max and total are exact and the median is over the last [`MEDIAN_WINDOW`] calls; the trace
//!   keeps the first [`TRACE_MAX_EVENTS`] events and counts the rest as dropped.
use super::context::Context;
use super::lifetime::Owned;
use crate::error::{Result, VkContext};
use ash::vk;
use std::collections::HashMap;

/// Calls per pass whose times are kept for the median.
pub const MEDIAN_WINDOW: usize = 4096;
/// Trace events kept (the first ones); later events are counted, not stored.
pub const TRACE_MAX_EVENTS: usize = 4096;

/// Running statistics of one pass (see the module invariants).
#[derive(Default)]
struct PassTimes {
    calls: usize,
    min: f64,
    max: f64,
    total: f64,
    recent: std::collections::VecDeque<f64>,
}

impl PassTimes {
    fn push(&mut self, ms: f64) {
        if self.calls == 0 {
            (self.min, self.max) = (ms, ms);
        }
        self.calls += 1;
        self.min = self.min.min(ms);
        self.max = self.max.max(ms);
        self.total += ms;
        if self.recent.len() == MEDIAN_WINDOW {
            self.recent.pop_front();
        }
        self.recent.push_back(ms);
    }
}

/// A scope opened by [`Profiler::begin`]; close it with [`Profiler::end`].
#[derive(Clone, Copy, Debug)]
#[must_use = "close the scope with Profiler::end"]
pub struct Scope {
    slot: usize,
    index: usize,
}

#[derive(Default)]
struct Slot {
    scopes: Vec<(String, u32, u32)>,
    next_query: u32,
    recorded: bool,
}

/// One complete timing of a scope.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TraceEvent {
    pub name: String,
    /// Start, in nanoseconds since the first collected timestamp.
    pub start_ns: f64,
    pub duration_ns: f64,
    pub frame: u64,
}

/// Statistics of one pass.
#[derive(Clone, Debug, serde::Serialize)]
pub struct PassStats {
    pub name: String,
    pub calls: usize,
    pub min_ms: f64,
    pub median_ms: f64,
    pub max_ms: f64,
    pub total_ms: f64,
}

/// The per-pass timestamp profiler. See the module invariants.
pub struct Profiler {
    pools: Vec<Owned<vk::QueryPool>>,
    slots: Vec<Slot>,
    capacity: u32,
    enabled: bool,
    period_ns: f64,
    valid_mask: u64,
    order: Vec<String>,
    times_ms: HashMap<String, PassTimes>,
    trace: Vec<TraceEvent>,
    trace_dropped: u64,
    origin: Option<u64>,
    frames_collected: u64,
    device_name: String,
}

impl Profiler {
    /// A profiler with `frames` slots of up to `max_scopes` scopes each.
    pub fn new(ctx: &Context, frames: usize, max_scopes: u32) -> Result<Self> {
        let enabled = ctx.info.timestamps_supported;
        let capacity = max_scopes.max(1) * 2;
        let mut pools = Vec::new();
        if enabled {
            for i in 0..frames.max(1) {
                let info = vk::QueryPoolCreateInfo::default()
                    .query_type(vk::QueryType::TIMESTAMP)
                    .query_count(capacity);
                // SAFETY: valid create info.
                let pool =
                    unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
                let pool = ctx.own(pool, &format!("profiler slot {i}"));
                // SAFETY: hostQueryReset is enabled on every gregvox device.
                unsafe { ctx.device.reset_query_pool(pool.raw(), 0, capacity) };
                pools.push(pool);
            }
        }
        let bits = ctx.info.timestamp_valid_bits;
        Ok(Profiler {
            slots: (0..frames.max(1)).map(|_| Slot::default()).collect(),
            pools,
            capacity,
            enabled,
            period_ns: ctx.info.timestamp_period_ns as f64,
            valid_mask: if bits >= 64 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            },
            order: Vec::new(),
            times_ms: HashMap::new(),
            trace: Vec::new(),
            trace_dropped: 0,
            origin: None,
            frames_collected: 0,
            device_name: ctx.info.name.clone(),
        })
    }

    /// Whether timestamps are recorded at all.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Opens a scope named `name` in frame slot `slot`: writes a timestamp after all earlier work.
    pub fn begin(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        slot: usize,
        name: &str,
    ) -> Scope {
        let s = &mut self.slots[slot];
        let index = s.scopes.len();
        if !self.enabled || s.next_query + 2 > self.capacity {
            if self.enabled && s.next_query + 2 > self.capacity {
                log::warn!(
                    "profiler: more than {} scopes in one frame; '{name}' not timed",
                    self.capacity / 2
                );
            }
            return Scope {
                slot,
                index: usize::MAX,
            };
        }
        let q = s.next_query;
        s.next_query += 2;
        s.scopes.push((name.to_owned(), q, q + 1));
        s.recorded = true;
        // SAFETY: q is a freshly reset query of this slot's pool.
        unsafe {
            ctx.device.cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                self.pools[slot].raw(),
                q,
            )
        };
        Scope { slot, index }
    }

    /// Closes `scope`: writes a timestamp once all earlier work has completed.
    pub fn end(&mut self, ctx: &Context, cmd: vk::CommandBuffer, scope: Scope) {
        if scope.index == usize::MAX {
            return;
        }
        let q = self.slots[scope.slot].scopes[scope.index].2;
        // SAFETY: q was reserved by `begin` in the same slot.
        unsafe {
            ctx.device.cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                self.pools[scope.slot].raw(),
                q,
            )
        };
    }

    /// Times `f` as one scope.
    pub fn scope<T>(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        slot: usize,
        name: &str,
        f: impl FnOnce() -> T,
    ) -> T {
        let s = self.begin(ctx, cmd, slot, name);
        let r = f();
        self.end(ctx, cmd, s);
        r
    }

    /// Adds `ms`, timed on the host (a pass that runs as native code on a CPU device, e.g. the host Gregory
    /// evaluator), to the statistics of `name`; it has no place in the trace, whose clock is the device's.
    /// A no-op where the profiler is disabled, like every other call.
    pub fn record_host(&mut self, name: &str, ms: f64) {
        if !self.enabled {
            return;
        }
        if !self.times_ms.contains_key(name) {
            self.order.push(name.to_string());
        }
        self.times_ms.entry(name.to_string()).or_default().push(ms);
    }

    /// Reads the results of `slot` (call after its fence has signalled), adds them to the statistics and
    /// resets the slot for reuse.
    pub fn collect(&mut self, ctx: &Context, slot: usize) -> Result<()> {
        if !self.enabled || !self.slots[slot].recorded {
            return Ok(());
        }
        let used = self.slots[slot].next_query;
        let mut ticks = vec![0u64; used as usize];
        // SAFETY: all `used` queries were written by a submission whose fence the caller waited for.
        unsafe {
            ctx.device.get_query_pool_results(
                self.pools[slot].raw(),
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let scopes = std::mem::take(&mut self.slots[slot].scopes);
        let frame = self.frames_collected;
        for (name, b, e) in scopes {
            let t0 = ticks[b as usize] & self.valid_mask;
            let t1 = ticks[e as usize] & self.valid_mask;
            let dt = t1.wrapping_sub(t0) & self.valid_mask;
            let origin = *self.origin.get_or_insert(t0);
            let ms = dt as f64 * self.period_ns * 1e-6;
            if !self.times_ms.contains_key(&name) {
                self.order.push(name.clone());
            }
            self.times_ms.entry(name.clone()).or_default().push(ms);
            if self.trace.len() < TRACE_MAX_EVENTS {
                self.trace.push(TraceEvent {
                    name,
                    start_ns: (t0.wrapping_sub(origin) & self.valid_mask) as f64 * self.period_ns,
                    duration_ns: dt as f64 * self.period_ns,
                    frame,
                });
            } else {
                self.trace_dropped += 1;
            }
        }
        self.frames_collected += 1;
        // SAFETY: the slot's queries are no longer in use.
        unsafe {
            ctx.device
                .reset_query_pool(self.pools[slot].raw(), 0, self.capacity)
        };
        let s = &mut self.slots[slot];
        s.next_query = 0;
        s.recorded = false;
        Ok(())
    }

    /// Per-pass statistics in first-seen order.
    pub fn stats(&self) -> Vec<PassStats> {
        self.order
            .iter()
            .map(|name| {
                let t = &self.times_ms[name];
                let mut v: Vec<f64> = t.recent.iter().copied().collect();
                v.sort_by(f64::total_cmp);
                let n = v.len();
                let median = if n % 2 == 1 {
                    v[n / 2]
                } else {
                    0.5 * (v[n / 2 - 1] + v[n / 2])
                };
                PassStats {
                    name: name.clone(),
                    calls: t.calls,
                    min_ms: t.min,
                    median_ms: median,
                    max_ms: t.max,
                    total_ms: t.total,
                }
            })
            .collect()
    }

    /// The timed scopes in collection order (the first [`TRACE_MAX_EVENTS`]).
    pub fn trace(&self) -> &[TraceEvent] {
        &self.trace
    }

    /// The per-pass table (markdown).
    pub fn table(&self) -> String {
        let mut s = format!("GPU passes on {} (timestamp queries)\n\n", self.device_name);
        if !self.enabled {
            s.push_str("(timestamps are not supported on this queue: nothing was timed)\n");
            return s;
        }
        s.push_str("| pass | calls | min ms | median ms | max ms |\n|---|---:|---:|---:|---:|\n");
        for p in self.stats() {
            s.push_str(&format!(
                "| {} | {} | {:.4} | {:.4} | {:.4} |\n",
                p.name, p.calls, p.min_ms, p.median_ms, p.max_ms
            ));
        }
        s
    }

    /// The profile JSON of docs/ARCHITECTURE.md:
    /// `{"device", "passes": [{"name", "calls", "gpu_ms": {min, median, max}}]}`.
    pub fn json(&self) -> serde_json::Value {
        let passes: Vec<serde_json::Value> = self
            .stats()
            .into_iter()
            .map(|p| {
                serde_json::json!({
                    "name": p.name,
                    "calls": p.calls,
                    "gpu_ms": {"min": p.min_ms, "median": p.median_ms, "max": p.max_ms},
                })
            })
            .collect();
        serde_json::json!({ "device": self.device_name, "timestamps": self.enabled, "passes": passes })
    }

    /// A chrome://tracing (Trace Event Format) document of every timed scope.
    pub fn chrome_trace(&self) -> serde_json::Value {
        let events: Vec<serde_json::Value> = self
            .trace
            .iter()
            .map(|e| {
                serde_json::json!({
                    "name": e.name, "cat": "gpu", "ph": "X", "pid": 1, "tid": 1,
                    "ts": e.start_ns * 1e-3, "dur": e.duration_ns * 1e-3,
                    "args": {"frame": e.frame},
                })
            })
            .collect();
        serde_json::json!({ "traceEvents": events, "displayTimeUnit": "ms",
                            "otherData": {"device": self.device_name, "dropped_events": self.trace_dropped} })
    }
}

/// Runs `f`, inside a timestamp scope `name` when a profiler (and its slot) is given: the form of the
/// optional profiler the passes' `record` functions take.
pub fn scoped<T>(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    profiler: &mut Option<(&mut Profiler, usize)>,
    name: &str,
    f: impl FnOnce() -> T,
) -> T {
    match profiler.as_mut() {
        Some((p, slot)) => p.scope(ctx, cmd, *slot, name, f),
        None => f(),
    }
}
