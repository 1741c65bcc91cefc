//! A session's requests in flight (queued or running), by request id, with the controls that
//! stop them. Ids are the client's: two requests may share one, and `Cancel` of that id stops
//! every request in flight under it (docs/protocol.md), not only the last sent.

use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use super::worker::RenderCtl;
use crate::lock;

#[derive(Default)]
pub(super) struct InFlight {
    by_id: Mutex<HashMap<u64, Vec<Arc<RenderCtl>>>>,
}

impl InFlight {
    pub(super) fn add(&self, request_id: u64, ctl: Arc<RenderCtl>) {
        lock(&self.by_id).entry(request_id).or_default().push(ctl);
    }

    /// Forgets `ctl` (its request replied, or was never queued).
    pub(super) fn remove(&self, request_id: u64, ctl: &Arc<RenderCtl>) {
        let mut by_id = lock(&self.by_id);
        if let Some(ctls) = by_id.get_mut(&request_id) {
            ctls.retain(|c| !Arc::ptr_eq(c, ctl));
            if ctls.is_empty() {
                by_id.remove(&request_id);
            }
        }
    }

    /// Cancels every request in flight under `request_id`; how many there were.
    pub(super) fn cancel(&self, request_id: u64) -> usize {
        let by_id = lock(&self.by_id);
        let ctls = by_id.get(&request_id).map_or(&[][..], |c| &c[..]);
        for ctl in ctls {
            ctl.cancel.cancel();
        }
        ctls.len()
    }

    /// Cancels every request in flight, or (`queued_only`) those not started yet.
    pub(super) fn cancel_all(&self, queued_only: bool) {
        for ctl in lock(&self.by_id).values().flatten() {
            if !(queued_only && ctl.started.load(Ordering::Relaxed)) {
                ctl.cancel.cancel();
            }
        }
    }
}
