//! A counting semaphore for renders, first come first served, whose waiters hear their place in
//! the queue, can give up (a cancelled render leaves the queue) and have a deadline; each slot
//! renders on its own thread pool. A long holder (a `Compare` or `Trade`, pass after pass)
//! shares its slot: between passes it lets those waiting go first ([`Slot::share`]).

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, OnceLock};
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
    pool: OnceLock<Option<Arc<ThreadPool>>>,
    /// False while [`Slot::share`] has given the slot up (and after it gave up waiting).
    held: AtomicBool,
}

/// What [`Slot::share`] did.
#[derive(Debug, PartialEq, Eq)]
pub enum Sharing {
    /// Nobody was waiting: the slot was kept.
    Kept,
    /// The slot went to those waiting and came back after them.
    Yielded,
    /// `give_up` turned true while waiting to have it back: the slot is not held.
    GaveUp,
}

impl Slot<'_> {
    fn new(slots: &RenderSlots) -> Slot<'_> {
        Slot {
            slots,
            pool: OnceLock::new(),
            held: AtomicBool::new(true),
        }
    }

    /// Runs `f` on this slot's thread pool (the process-wide pool if a new one cannot be made).
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        let pool = self.pool.get_or_init(|| {
            lock(&self.slots.pools).pop().or_else(|| {
                let n = rayon::current_num_threads();
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .thread_name(|i| format!("render-pool-{i}"))
                    .build()
                    .inspect_err(|e| tracing::warn!(error = %e, "no thread pool for a render slot"))
                    .ok()
                    .map(Arc::new)
            })
        });
        match pool {
            Some(pool) => pool.install(f),
            None => f(),
        }
    }

    /// Between two passes of a long request: if renders wait for a slot, gives this one up and
    /// queues for it again behind them (hearing its place through `on_place`, as
    /// [`RenderSlots::acquire`]), so that no request waits behind another's whole sweep. No
    /// deadline: the request was admitted, and those ahead are bounded by their own passes.
    /// This slot's thread pool stays with it (its thread is the one waiting).
    pub fn share(&self, give_up: impl Fn() -> bool, on_place: impl FnMut(usize)) -> Sharing {
        let mut s = lock(&self.slots.state);
        if s.waiting.is_empty() {
            return Sharing::Kept;
        }
        // Given up and queued for again under one lock: those waiting are ahead.
        s.running -= 1;
        self.held.store(false, Ordering::Relaxed);
        self.slots.cv.notify_all();
        match self.slots.queue(s, give_up, None, on_place) {
            Queued::Took(_) => {
                self.held.store(true, Ordering::Relaxed);
                Sharing::Yielded
            }
            // Without a deadline only `give_up` ends the wait.
            Queued::GaveUp | Queued::TimedOut { .. } => Sharing::GaveUp,
        }
    }
}

impl Drop for Slot<'_> {
    fn drop(&mut self) {
        if let Some(Some(pool)) = self.pool.take() {
            lock(&self.slots.pools).push(pool);
        }
        if !self.held.load(Ordering::Relaxed) {
            return;
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
        on_place: impl FnMut(usize),
    ) -> Acquired<'_> {
        let mut s = lock(&self.state);
        if s.running < self.max && s.waiting.is_empty() {
            s.running += 1;
            return Acquired::Slot(Slot::new(self), 0);
        }
        match self.queue(s, give_up, max_wait, on_place) {
            Queued::Took(first_position) => Acquired::Slot(Slot::new(self), first_position),
            Queued::GaveUp => Acquired::GaveUp,
            Queued::TimedOut { position, waited } => Acquired::TimedOut { position, waited },
        }
    }

    /// Joins the back of the queue (`s`: the state, locked) and waits until a slot is free at
    /// its head, then counts it as running; as [`acquire`](Self::acquire) for the rest.
    fn queue<'a>(
        &'a self,
        mut s: std::sync::MutexGuard<'a, State>,
        give_up: impl Fn() -> bool,
        max_wait: Option<Duration>,
        mut on_place: impl FnMut(usize),
    ) -> Queued {
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
                return Queued::GaveUp;
            }
            if s.running < self.max && position == 1 {
                s.waiting.pop_front();
                s.running += 1;
                drop(s);
                // The next in line may fit too, and everyone behind moved up.
                self.cv.notify_all();
                return Queued::Took(first_position);
            }
            let waited = joined.elapsed();
            if max_wait.is_some_and(|m| waited >= m) {
                leave(s);
                return Queued::TimedOut { position, waited };
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

/// How a wait in the queue ended.
enum Queued {
    /// A slot, counted as running; the place at which the wait began.
    Took(usize),
    GaveUp,
    TimedOut {
        position: usize,
        waited: Duration,
    },
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

    #[test]
    fn a_holder_shares_its_slot_with_those_waiting() {
        let slots = Arc::new(RenderSlots::new(1));
        let held = match slots.acquire(never, None, |_| {}) {
            Acquired::Slot(s, 0) => s,
            _ => panic!("expected a free slot"),
        };
        // Nobody waits: the slot is kept.
        assert_eq!(
            held.share(never, |_| panic!("no wait expected")),
            Sharing::Kept
        );
        let order = Arc::new(Mutex::new(Vec::new()));
        let waiter = {
            let (s, order) = (slots.clone(), order.clone());
            std::thread::spawn(move || match s.acquire(never, None, |_| {}) {
                Acquired::Slot(slot, _) => {
                    order.lock().unwrap().push("waiter");
                    std::thread::sleep(Duration::from_millis(50));
                    drop(slot);
                }
                _ => panic!("expected a slot"),
            })
        };
        while slots.load().1 < 1 {
            std::thread::sleep(Duration::from_millis(1));
        }
        let mut places = Vec::new();
        assert_eq!(held.share(never, |p| places.push(p)), Sharing::Yielded);
        order.lock().unwrap().push("holder");
        waiter.join().unwrap();
        assert_eq!(*order.lock().unwrap(), ["waiter", "holder"]);
        assert_eq!(places.first(), Some(&2));
        assert_eq!(slots.load(), (1, 0));
        // A holder that gives up while waiting to have its slot back holds none.
        let other = {
            let s = slots.clone();
            std::thread::spawn(move || match s.acquire(never, None, |_| {}) {
                Acquired::Slot(_slot, _) => std::thread::sleep(Duration::from_millis(300)),
                _ => panic!("expected a slot"),
            })
        };
        while slots.load().1 < 1 {
            std::thread::sleep(Duration::from_millis(1));
        }
        let gone = std::sync::atomic::AtomicBool::new(false);
        let shared = held.share(
            || gone.load(Ordering::Relaxed),
            |_| gone.store(true, Ordering::Relaxed),
        );
        assert_eq!(shared, Sharing::GaveUp);
        drop(held);
        other.join().unwrap();
        assert_eq!(slots.load(), (0, 0));
    }
}
