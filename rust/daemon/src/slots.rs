//! A counting semaphore for renders, first come first served, whose waiters can give up (a
//! cancelled render leaves the queue).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use crate::lock;

struct State {
    running: usize,
    next_ticket: u64,
    waiting: VecDeque<u64>,
}

pub struct RenderSlots {
    max: usize,
    state: Mutex<State>,
    cv: Condvar,
}

/// Holds one render slot; dropping it frees the slot.
pub struct Slot<'a> {
    slots: &'a RenderSlots,
}

impl Drop for Slot<'_> {
    fn drop(&mut self) {
        let mut s = lock(&self.slots.state);
        s.running -= 1;
        drop(s);
        self.slots.cv.notify_all();
    }
}

/// What [`RenderSlots::acquire`] saw before it got a slot.
pub enum Acquired<'a> {
    /// A slot, and how many renders were ahead in the queue when it joined (0: no wait).
    Slot(Slot<'a>, usize),
    /// `give_up` became true while waiting.
    GaveUp,
}

impl RenderSlots {
    pub fn new(max: usize) -> Self {
        RenderSlots {
            max: max.max(1),
            state: Mutex::new(State {
                running: 0,
                next_ticket: 0,
                waiting: VecDeque::new(),
            }),
            cv: Condvar::new(),
        }
    }

    /// Renders running now and waiting now.
    pub fn load(&self) -> (usize, usize) {
        let s = lock(&self.state);
        (s.running, s.waiting.len())
    }

    /// Takes a slot, waiting in line if all are taken. `on_queued(position)` is called once if
    /// the caller has to wait (position 1: next in line). Gives up when `give_up` is set.
    pub fn acquire(&self, give_up: &AtomicBool, on_queued: impl FnOnce(usize)) -> Acquired<'_> {
        let mut s = lock(&self.state);
        if s.running < self.max && s.waiting.is_empty() {
            s.running += 1;
            return Acquired::Slot(Slot { slots: self }, 0);
        }
        let ticket = s.next_ticket;
        s.next_ticket += 1;
        s.waiting.push_back(ticket);
        let position = s.waiting.len();
        drop(s);
        on_queued(position);
        let mut s = lock(&self.state);
        loop {
            if give_up.load(Ordering::Relaxed) {
                s.waiting.retain(|&t| t != ticket);
                drop(s);
                self.cv.notify_all();
                return Acquired::GaveUp;
            }
            if s.running < self.max && s.waiting.front() == Some(&ticket) {
                s.waiting.pop_front();
                s.running += 1;
                drop(s);
                // The next in line may fit too.
                self.cv.notify_all();
                return Acquired::Slot(Slot { slots: self }, position);
            }
            s = match self.cv.wait_timeout(s, Duration::from_millis(50)) {
                Ok((g, _)) => g,
                Err(p) => p.into_inner().0,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn bounds_and_queues_in_order() {
        let slots = Arc::new(RenderSlots::new(1));
        let never = AtomicBool::new(false);
        let first = match slots.acquire(&never, |_| panic!("no wait expected")) {
            Acquired::Slot(s, 0) => s,
            _ => panic!("expected a free slot"),
        };
        let order = Arc::new(Mutex::new(Vec::new()));
        let mut threads = Vec::new();
        for i in 0..3 {
            let (s, order) = (slots.clone(), order.clone());
            threads.push(std::thread::spawn(move || {
                let never = AtomicBool::new(false);
                let mut queued_at = 0;
                match s.acquire(&never, |p| queued_at = p) {
                    Acquired::Slot(_s, _) => order.lock().unwrap().push(i),
                    Acquired::GaveUp => unreachable!(),
                }
                queued_at
            }));
            // Let each thread join the queue before the next.
            while slots.load().1 < i + 1 {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        drop(first);
        let positions: Vec<usize> = threads.into_iter().map(|t| t.join().unwrap()).collect();
        assert_eq!(positions, vec![1, 2, 3]);
        assert_eq!(*order.lock().unwrap(), vec![0, 1, 2]);
        assert_eq!(slots.load(), (0, 0));
    }

    #[test]
    fn waiter_can_give_up() {
        let slots = RenderSlots::new(1);
        let never = AtomicBool::new(false);
        let _held = slots.acquire(&never, |_| {});
        let give_up = AtomicBool::new(true);
        assert!(matches!(slots.acquire(&give_up, |_| {}), Acquired::GaveUp));
        assert_eq!(slots.load(), (1, 0));
    }
}
