//! A `Render`, `Compare` or `Trade` admitted by a session: the frame's scene and what to do
//! with it, for the session's [`crate::SessionRenderer`].

use antumbra_core::render::RenderSettings;
use antumbra_core::scene::Scene;
use antumbra_protocol::{CompareRequest, Passes, TradeRequest, COMPARE_STAGE, TRADE_STAGE};

use crate::renderer::RENDER_STAGE;

pub struct Job {
    /// The client's id, echoed in every reply to the job.
    pub request_id: u64,
    pub scene: Scene,
    pub kind: JobKind,
}

pub enum JobKind {
    Render {
        settings: RenderSettings,
        /// The planes the reply carries.
        passes: Passes,
        /// The frame for the session's state only (`RenderRequest::warm_up`).
        warm_up: bool,
    },
    Compare(CompareRequest),
    Trade(TradeRequest),
}

impl Job {
    /// The request's name in messages.
    pub fn what(&self) -> &'static str {
        match self.kind {
            JobKind::Render { .. } => "Render",
            JobKind::Compare(_) => "Compare",
            JobKind::Trade(_) => "Trade",
        }
    }

    /// The `Progress` stage of the job's work: a render's first, or the stage of a
    /// comparison's or trade's passes.
    pub fn stage(&self) -> &'static str {
        match self.kind {
            JobKind::Render { .. } => RENDER_STAGE,
            JobKind::Compare(_) => COMPARE_STAGE,
            JobKind::Trade(_) => TRADE_STAGE,
        }
    }

    pub fn frame(&self) -> i32 {
        self.scene.frame
    }
}
