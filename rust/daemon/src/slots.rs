//! A counting semaphore for renders, first come first served, whose waiters hear their place in
//! the queue, can give up (a cancelled render leaves the queue) and have a deadline; each slot
//! renders on its own thread pool.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use rayon::ThreadPool;

use crate::lock;

/// A waiter hears its place at least this often, so a client's wait between replies is bounded.
pub const QUEUE_HEARTBEAT: Duration = Duration::from_secs(10);

struct State {
    running: usize,
    next_ticket: u64,
    waiting: VecDeque<u64>,
}

pub struct RenderSlots {
    max: usize,
    state: Mutex<State>,
    cv: Condvar,
    /// The thread pools of the slots not in use, built on first use. A render runs on its
    /// slot's own pool: in a shared pool a thread waiting inside one render's parallel loop
    /// steals another render's work, so a cancelled render could not end before that work did.
    pools: Mutex<Vec<Arc<ThreadPool>>>,
}

/// Holds one render slot; dropping it frees the slot.
pub struct Slot<'a> {
    slots: &'a RenderSlots,
    pool: Option<Arc<ThreadPool>>,
}

impl Slot<'_> {
    fn new(slots: &RenderSlots) -> Slot<'_> {
        Slot { slots, pool: None }
    }

    /// Runs `f` on this slot's thread pool (the process-wide pool if a new one cannot be made).
    pub fn install<R: Send>(&mut self, f: impl FnOnce() -> R + Send) -> R {
        if self.pool.is_none() {
            self.pool = lock(&self.slots.pools).pop().or_else(|| {
                let n = rayon::current_num_threads();
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .thread_name(|i| format!("render-pool-{i}"))
                    .build()
                    .inspect_err(|e| tracing::warn!(error = %e, "no thread pool for a render slot"))
                    .ok()
                    .map(Arc::new)
            });
        }
        match &self.pool {
            Some(pool) => pool.install(f),
            None => f(),
        }
    }
}

impl Drop for Slot<'_> {
    fn drop(&mut self) {
        if let Some(pool) = self.pool.take() {
            lock(&self.slots.pools).push(pool);
        }
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
    /// The wait reached its deadline at this place in the queue (1: next in line).
    TimedOut { position: usize, waited: Duration },
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
            pools: Mutex::new(Vec::new()),
        }
    }

    /// Renders running now and waiting now.
    pub fn load(&self) -> (usize, usize) {
        let s = lock(&self.state);
        (s.running, s.waiting.len())
    }

    /// Takes a slot, waiting in line if all are taken. While it waits, `on_place(position)`
    /// (1: next in line) is called when it joins, when its place changes and at least every
    /// [`QUEUE_HEARTBEAT`]; never with the lock held. Gives up when `give_up()` turns true, or
    /// after `max_wait`.
    pub fn acquire(
        &self,
        give_up: impl Fn() -> bool,
        max_wait: Option<Duration>,
        mut on_place: impl FnMut(usize),
    ) -> Acquired<'_> {
        let mut s = lock(&self.state);
        if s.running < self.max && s.waiting.is_empty() {
            s.running += 1;
            return Acquired::Slot(Slot::new(self), 0);
        }
        let joined = Instant::now();
        let ticket = s.next_ticket;
        s.next_ticket += 1;
        s.waiting.push_back(ticket);
        let first_position = s.waiting.len();
        let mut told: Option<(usize, Instant)> = None;
        loop {
            let position = s
                .waiting
                .iter()
                .position(|&t| t == ticket)
                .map_or(0, |p| p + 1);
            let leave = |mut s: std::sync::MutexGuard<'_, State>| {
                s.waiting.retain(|&t| t != ticket);
                drop(s);
                // Those behind move up.
                self.cv.notify_all();
            };
            if give_up() {
                leave(s);
                return Acquired::GaveUp;
            }
            if s.running < self.max && position == 1 {
                s.waiting.pop_front();
                s.running += 1;
                drop(s);
                // The next in line may fit too, and everyone behind moved up.
                self.cv.notify_all();
                return Acquired::Slot(Slot::new(self), first_position);
            }
            let waited = joined.elapsed();
            if max_wait.is_some_and(|m| waited >= m) {
                leave(s);
                return Acquired::TimedOut { position, waited };
            }
            if told.is_none_or(|(p, at)| p != position || at.elapsed() >= QUEUE_HEARTBEAT) {
                drop(s);
                on_place(position);
                told = Some((position, Instant::now()));
                s = lock(&self.state);
                continue;
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

    fn never() -> bool {
        false
    }

    #[test]
    fn bounds_and_queues_in_order() {
        let slots = Arc::new(RenderSlots::new(1));
        let first = match slots.acquire(never, None, |_| panic!("no wait expected")) {
            Acquired::Slot(s, 0) => s,
            _ => panic!("expected a free slot"),
        };
        let order = Arc::new(Mutex::new(Vec::new()));
        let mut threads = Vec::new();
        for i in 0..3 {
            let (s, order) = (slots.clone(), order.clone());
            threads.push(std::thread::spawn(move || {
                let mut queued_at = 0;
                match s.acquire(never, None, |p| {
                    if queued_at == 0 {
                        queued_at = p;
                    }
                }) {
                    Acquired::Slot(_s, _) => order.lock().unwrap().push(i),
                    _ => unreachable!(),
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
        let _held = slots.acquire(never, None, |_| {});
        assert!(matches!(
            slots.acquire(|| true, None, |_| {}),
            Acquired::GaveUp
        ));
        assert_eq!(slots.load(), (1, 0));
    }

    #[test]
    fn waiters_hear_their_place_move_up_and_time_out() {
        let slots = Arc::new(RenderSlots::new(1));
        let _held = slots.acquire(never, None, |_| {});
        let places = Arc::new(Mutex::new(Vec::new()));
        let leave = Arc::new(std::sync::atomic::AtomicBool::new(false));
        let first = {
            let (s, leave) = (slots.clone(), leave.clone());
            std::thread::spawn(move || {
                let gone = || leave.load(std::sync::atomic::Ordering::Relaxed);
                matches!(s.acquire(gone, None, |_| {}), Acquired::GaveUp)
            })
        };
        while slots.load().1 < 1 {
            std::thread::sleep(Duration::from_millis(1));
        }
        let second = {
            let (s, places) = (slots.clone(), places.clone());
            std::thread::spawn(move || {
                let wait = Some(Duration::from_secs(2));
                match s.acquire(never, wait, |p| places.lock().unwrap().push(p)) {
                    Acquired::TimedOut { position, waited } => (position, waited),
                    _ => panic!("expected a timeout"),
                }
            })
        };
        while places.lock().unwrap().is_empty() {
            std::thread::sleep(Duration::from_millis(1));
        }
        leave.store(true, std::sync::atomic::Ordering::Relaxed);
        assert!(first.join().unwrap());
        let (position, waited) = second.join().unwrap();
        assert_eq!(*places.lock().unwrap(), vec![2, 1]);
        assert_eq!(position, 1);
        assert!(waited >= Duration::from_secs(2));
        assert_eq!(slots.load(), (1, 0));
    }
}
