//! What runs a session's jobs: the session's `Renderer` (trees reused across frames), its
//! comparison and its trade, one job at a time. The daemon runs it on the session's render
//! worker inside a render slot, `LocalSession` in the caller's thread, the spool per job.

use antumbra_core::cancel::CancelToken;
use antumbra_core::render::{FrameResult, Renderer, WarmUp};
use antumbra_protocol::{
    frame_result_reply, warm_up_reply, CompareResultReply, ProtocolError, Reply, TradeResultReply,
};

use crate::compare::CompareState;
use crate::job::{Job, JobKind};
use crate::trade::TradeState;

/// The `Progress` stages of a `Render`: (`RENDER_STAGE`, 0, `RENDER_STAGES`) before rendering,
/// (`ENCODE_STAGE`, 1, `RENDER_STAGES`) after (a `Compare` or `Trade` counts its passes).
pub const RENDER_STAGE: &str = "render";
pub const ENCODE_STAGE: &str = "encode";
pub const RENDER_STAGES: u32 = 2;

/// What a job produced. A frame stays core's result until [`Done::into_reply`], so the daemon
/// encodes it outside its render slot and the spool writes its files from it directly.
pub enum Done {
    Frame(Box<FrameResult>),
    WarmUp(WarmUp),
    Compare(CompareResultReply),
    Trade(TradeResultReply),
}

impl Done {
    /// The reply to `job` (a frame carries the planes the job asked for).
    pub fn into_reply(self, job: &Job) -> Reply {
        let passes = match &job.kind {
            JobKind::Render { passes, .. } => *passes,
            _ => Default::default(),
        };
        match self {
            Done::Frame(r) => Reply::FrameResult(frame_result_reply(&r, job.request_id, &passes)),
            Done::WarmUp(w) => Reply::FrameResult(warm_up_reply(&w, job.request_id, &passes)),
            Done::Compare(c) => Reply::CompareResult(c),
            Done::Trade(t) => Reply::TradeResult(t),
        }
    }
}

#[derive(Default)]
pub struct SessionRenderer {
    renderer: Renderer,
    comparison: CompareState,
    trade: TradeState,
}

impl SessionRenderer {
    pub fn new() -> Self {
        Self::default()
    }

    /// Runs `job`, reading `cancel` per tile; a `Compare` or `Trade` calls `progress(done,
    /// total)` before its first pass and after each (a `Render` reports nothing: its stages are
    /// the caller's). `label` names the statistics rows (the `scene` column). A cancelled job is
    /// `Err` with code `Cancelled`; it leaves the comparison or trade as before the frame.
    pub fn run(
        &mut self,
        job: &Job,
        label: &str,
        cancel: &CancelToken,
        progress: &mut (dyn FnMut(u32, u32) + Send),
    ) -> Result<Done, ProtocolError> {
        let scene = &job.scene;
        let in_frame = |error| ProtocolError::InFrame {
            frame: scene.frame,
            error,
        };
        match &job.kind {
            JobKind::Render {
                settings,
                warm_up: true,
                ..
            } => self
                .renderer
                .warm_up_cancellable(scene, settings, cancel)
                .map(Done::WarmUp)
                .map_err(in_frame),
            JobKind::Render { settings, .. } => self
                .renderer
                .render_cancellable(label, scene, settings, cancel)
                .map(|r| Done::Frame(Box::new(r)))
                .map_err(in_frame),
            JobKind::Compare(request) => self
                .comparison
                .frame(request, label, scene, cancel, progress)
                .map(Done::Compare),
            JobKind::Trade(request) => self
                .trade
                .frame(request, label, scene, cancel, progress)
                .map(Done::Trade),
        }
    }

    /// After a panic in [`run`](Self::run): the renderer's trees may be half-updated, so it
    /// starts afresh (a comparison or trade was taken out while it ran and is gone already).
    pub fn after_panic(&mut self) {
        self.renderer = Renderer::new();
    }

    /// Drops everything the session's jobs built (the session ends).
    pub fn clear(&mut self) {
        *self = Self::new();
    }
}
