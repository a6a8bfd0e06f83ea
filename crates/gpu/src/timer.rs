//! GPU pass timing with timestamp queries (through wgpu-profiler): each pass asks for its
//! begin/end timestamp writes, the queries are resolved once per frame, and finished frames
//! are read back a few frames later without stalling. Without TIMESTAMP_QUERY every call is
//! a no-op and no times are reported. Depends on wgpu and wgpu-profiler.

use wgpu_profiler::{GpuProfiler, GpuProfilerQuery, GpuProfilerSettings};

use crate::context::GpuContext;
use crate::error::GpuError;

/// Times passes of the frames recorded through it.
pub struct GpuTimer {
    profiler: GpuProfiler,
    period: f32,
    enabled: bool,
}

/// An open pass timing; give its writes to the pass descriptor, then [`GpuTimer::end`] it.
pub struct PassTimer(GpuProfilerQuery);

impl PassTimer {
    /// Timestamp writes for a render pass (None without timestamp support).
    pub fn render_writes(&self) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.0.render_pass_timestamp_writes()
    }
    /// Timestamp writes for a compute pass (None without timestamp support).
    pub fn compute_writes(&self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.0.compute_pass_timestamp_writes()
    }
}

/// One pass's GPU time in a finished frame.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTime {
    /// The pass label (e.g. "forward.cull").
    pub label: String,
    /// Milliseconds.
    pub ms: f64,
}

impl GpuTimer {
    /// A timer for `ctx` (disabled when the device has no timestamps).
    pub fn new(ctx: &GpuContext) -> Result<Self, GpuError> {
        let settings = GpuProfilerSettings {
            enable_timer_queries: ctx.timestamps,
            enable_debug_groups: false,
            max_num_pending_frames: 4,
        };
        let profiler =
            GpuProfiler::new(&ctx.device, settings).map_err(|e| GpuError::Config(format!("GPU timer: {e}")))?;
        Ok(Self { profiler, period: ctx.queue.get_timestamp_period(), enabled: ctx.timestamps })
    }

    /// True when passes are really timed.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// Opens the timing of a pass about to be recorded on `encoder`.
    pub fn begin(&self, label: &str, encoder: &mut wgpu::CommandEncoder) -> PassTimer {
        PassTimer(self.profiler.begin_pass_query(label, encoder))
    }

    /// Closes a pass timing after its pass ended.
    pub fn end(&self, encoder: &mut wgpu::CommandEncoder, t: PassTimer) {
        self.profiler.end_query(encoder, t.0);
    }

    /// One timed compute pass labelled `label`: begins it with its timestamps, lets
    /// `record` fill it, ends it and its timing.
    pub fn compute_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        record: impl FnOnce(&mut wgpu::ComputePass<'_>),
    ) {
        let t = self.begin(label, encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: t.compute_writes(),
            });
            record(&mut pass);
        }
        self.end(encoder, t);
    }

    /// Resolves this frame's queries; call once at the end of the frame's last encoder.
    pub fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.profiler.resolve_queries(encoder);
    }

    /// Marks the end of a frame (after submitting it).
    pub fn end_frame(&mut self) -> Result<(), GpuError> {
        self.profiler.end_frame().map_err(|e| GpuError::Config(format!("GPU timer: {e}")))
    }

    /// The pass times of the oldest finished frame, if one is ready.
    pub fn finished_frame(&mut self) -> Option<Vec<PassTime>> {
        self.finished_frame_and_span().map(|(passes, _)| passes)
    }

    /// The pass times of the oldest finished frame and its span: milliseconds from the
    /// first timed pass's start to the last one's end, so the untimed work and the gaps
    /// between passes are in it (None without a timed pass).
    pub fn finished_frame_and_span(&mut self) -> Option<(Vec<PassTime>, Option<f64>)> {
        let results = self.profiler.process_finished_frame(self.period)?;
        let mut out = Vec::new();
        flatten(&results, &mut out);
        let times = results.iter().filter_map(|r| r.time.clone());
        let span = times.fold(None, |acc: Option<(f64, f64)>, t| {
            Some(acc.map_or((t.start, t.end), |(s, e)| (s.min(t.start), e.max(t.end))))
        });
        Some((out, span.map(|(s, e)| (e - s) * 1000.0)))
    }
}

fn flatten(results: &[wgpu_profiler::GpuTimerQueryResult], out: &mut Vec<PassTime>) {
    for r in results {
        if let Some(t) = &r.time {
            out.push(PassTime { label: r.label.clone(), ms: (t.end - t.start) * 1000.0 });
        }
        flatten(&r.nested_queries, out);
    }
}
