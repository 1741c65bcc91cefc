//! One antumbra session, whoever serves it: the daemon's connections (`antumbra-daemon`, which
//! adds sockets, render slots, cancellation and progress), the in-process `LocalSession` of the
//! Python package, and the daemon's spool jobs.
//!
//! - [`SessionState`] holds what a client's requests build up (its meshes by hash, from a
//!   [`MeshCache`] it may share with other sessions, and its latest frames) and answers every
//!   request with [`SessionState::handle`]: at once, or as an admitted [`Job`].
//! - [`SessionRenderer`] runs the jobs: it owns the session's `Renderer` (tree reuse across
//!   frames), its [`CompareState`] and its [`TradeState`].

pub mod cache;
mod compare;
mod job;
mod renderer;
mod reply;
mod state;
mod trade;

pub use cache::{image_bytes, mesh_bytes, CacheStats, MeshCache};
pub use compare::CompareState;
pub use job::{Job, JobKind};
pub use renderer::{Done, SessionRenderer, ENCODE_STAGE, RENDER_STAGE, RENDER_STAGES};
pub use reply::{error_reply, protocol_error};
pub use state::{Control, Handled, SessionState, FRAMES_KEPT};
pub use trade::TradeState;

use std::sync::{Mutex, MutexGuard};

/// Locks a mutex, recovering the data if a thread panicked while holding it: what the session
/// locks stays consistent between statements, and one failed request must not poison the rest.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
