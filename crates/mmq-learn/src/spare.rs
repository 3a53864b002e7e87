//! Cores a learner may borrow for work whose result does not depend on where it runs.
//!
//! A run of `mmq` learns on one thread per seed. When fewer seeds run than the process
//! has threads (one seed of `mmq run`, the last seeds of a sweep), the other cores idle;
//! a learner can put one of them to work (the deconvolving learners run a refit's cold
//! start beside its warm one, and sort their new statistics between refits). The runner
//! says how many threads it runs learners on ([`set_threads`]) and counts the learners
//! running ([`Job`]); a learner takes a core only while one is free (`borrow`), so that
//! seeds in parallel never run more threads than there are. Without a runner (a learner
//! used as a library, or stepped one step at a time from Python) no core is spare and
//! everything runs on the caller's thread; Python's `mmq.run` goes through the runner.
//!
//! Borrowing changes no result: what runs on the borrowed core is a computation the
//! learner would otherwise make on its own thread, bit for bit.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock, PoisonError};
use std::thread::JoinHandle;

/// Threads to run learners on, and learners running plus cores lent.
#[derive(Debug)]
struct Lender {
    threads: AtomicUsize,
    busy: AtomicUsize,
}

impl Lender {
    const fn new() -> Self {
        Self { threads: AtomicUsize::new(0), busy: AtomicUsize::new(0) }
    }

    fn take(&self) {
        self.busy.fetch_add(1, Ordering::AcqRel);
    }

    fn give_back(&self) {
        self.busy.fetch_sub(1, Ordering::AcqRel);
    }

    /// Takes a core if one is neither running a learner nor lent.
    fn lend(&self) -> bool {
        let threads = self.threads.load(Ordering::Relaxed);
        self.busy
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |busy| (busy < threads).then(|| busy + 1))
            .is_ok()
    }
}

/// The process's: the runner's threads (0: no runner).
static LENDER: Lender = Lender::new();

#[cfg(test)]
thread_local! {
    /// Tests: whether refits on this thread always (Some(true)) or never borrow a core,
    /// whatever the process's counts.
    pub(crate) static FORCE: std::cell::Cell<Option<bool>> = const { std::cell::Cell::new(None) };
}

/// The runner runs learners on `n` threads (0 or 1: no core is ever spare).
pub fn set_threads(n: usize) {
    LENDER.threads.store(n, Ordering::Relaxed);
}

/// A learner running: holds one of the runner's threads until dropped.
#[derive(Debug)]
#[must_use = "the job counts as running only while this is held"]
pub struct Job(());

impl Job {
    /// A learner starts running on one of the runner's threads.
    pub fn start() -> Self {
        LENDER.take();
        Self(())
    }
}

impl Drop for Job {
    fn drop(&mut self) {
        LENDER.give_back();
    }
}

/// A borrowed core, given back when dropped.
#[derive(Debug)]
pub(crate) struct Core {
    counted: bool,
}

impl Drop for Core {
    fn drop(&mut self) {
        if self.counted {
            LENDER.give_back();
        }
    }
}

/// A core when one of the runner's threads is neither running a learner nor lent.
pub(crate) fn borrow() -> Option<Core> {
    #[cfg(test)]
    if let Some(force) = FORCE.with(std::cell::Cell::get) {
        return force.then(|| Core { counted: false });
    }
    LENDER.lend().then(|| Core { counted: true })
}

/// Runs `here` on this thread and `there` beside it on a borrowed core when one is free;
/// otherwise (or when the thread cannot start) `there` runs on this thread after `here`.
/// Returns both results; a panic in `there` is raised again here.
pub(crate) fn beside<A, B: Send>(here: impl FnOnce() -> A, there: impl FnOnce() -> B + Send) -> (A, B) {
    let Some(_core) = borrow() else {
        let a = here();
        return (a, there());
    };
    // The thread only borrows `there` and its result's slot: one that cannot start
    // leaves both where they were, for this thread.
    let (mut there, mut out) = (Some(there), None);
    let a = std::thread::scope(|scope| {
        let (job, slot) = (&mut there, &mut out);
        let thread = std::thread::Builder::new().name("mmq-spare".into()).spawn_scoped(scope, move || {
            if let Some(f) = job.take() {
                *slot = Some(f());
            }
        });
        let a = here();
        if let Ok(t) = thread {
            t.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        }
        a
    });
    let b = out.unwrap_or_else(|| there.take().expect("run on neither thread")());
    (a, b)
}

/// Work started on a lent core ([`lend`]), whose result [`Later::wait`] waits for.
/// Clones share the work and its result.
#[derive(Debug)]
pub(crate) struct Later<T> {
    inner: Arc<LaterInner<T>>,
}

#[derive(Debug)]
struct LaterInner<T> {
    result: OnceLock<T>,
    /// The thread, until a wait joins it.
    thread: Mutex<Option<JoinHandle<()>>>,
}

impl<T> Clone for Later<T> {
    fn clone(&self) -> Self {
        Self { inner: Arc::clone(&self.inner) }
    }
}

impl<T> Later<T> {
    /// The result, once the work has ended; a panic in it is raised again here.
    pub(crate) fn wait(&self) -> &T {
        // The lock is held while the thread is joined, so that a clone waiting at the
        // same time finds the result set.
        let mut thread = lock(&self.inner.thread);
        if let Some(t) = thread.take() {
            t.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        }
        drop(thread);
        self.inner.result.get().expect("work that ended without a panic left its result")
    }
}

/// Starts `f(data)` on a borrowed core, which it holds until `f` returns, when one is
/// free and its thread starts; otherwise gives `data` back.
pub(crate) fn lend<D, T>(data: D, f: fn(D) -> T) -> Result<Later<T>, D>
where
    D: Send + 'static,
    T: Send + Sync + 'static,
{
    let Some(core) = borrow() else { return Err(data) };
    let inner = Arc::new(LaterInner { result: OnceLock::new(), thread: Mutex::new(None) });
    // The data stays reachable from here until the thread takes it, so that a thread
    // that cannot start leaves it to be given back.
    let job = Arc::new(Mutex::new(Some(data)));
    let (slot, work) = (Arc::clone(&inner), Arc::clone(&job));
    let thread = std::thread::Builder::new().name("mmq-spare".into()).spawn(move || {
        let _core = core;
        let data = lock(&work).take();
        if let Some(data) = data {
            // The only place that sets it.
            let _ = slot.result.set(f(data));
        }
    });
    match thread {
        Ok(t) => {
            *lock(&inner.thread) = Some(t);
            Ok(Later { inner })
        }
        Err(_) => Err(lock(&job).take().expect("a thread that did not start took nothing")),
    }
}

/// The value of a mutex, also after a panic elsewhere while it was held (the values here
/// are only set whole).
fn lock<M>(m: &Mutex<M>) -> MutexGuard<'_, M> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With two threads and one job, one core is lent at a time and comes back when the
    /// loan ends; with two jobs none is; with no threads none ever is.
    #[test]
    fn lends_only_free_cores() {
        let l = Lender::new();
        assert!(!l.lend(), "no runner, no spare core");
        l.threads.store(2, Ordering::Relaxed);
        l.take();
        assert!(l.lend());
        assert!(!l.lend(), "the one free core is lent already");
        l.give_back();
        l.take();
        assert!(!l.lend(), "two jobs on two threads leave none free");
        l.give_back();
        assert!(l.lend(), "a job ended: its core is free");
    }

    /// `beside` returns both results in their places, with a core and without.
    #[test]
    fn beside_returns_both_results() {
        for force in [false, true] {
            FORCE.with(|f| f.set(Some(force)));
            let (mut x, mut y) = (0, 0);
            let (a, b) = beside(|| (x = 1, 2).1, || (y = 3, 4).1);
            FORCE.with(|f| f.set(None));
            assert_eq!((a, b, x, y), (2, 4, 1, 3));
        }
    }

    /// `lend` runs the work on a lent core and `wait` returns its result, to every clone;
    /// with no core free it gives the data back untouched; a panic in the work is raised
    /// in `wait`.
    #[test]
    fn lent_work_returns_its_result_or_its_data() {
        FORCE.with(|f| f.set(Some(true)));
        let later = lend(vec![3u64, 1, 2], |mut v| {
            v.sort_unstable();
            v
        })
        .expect("a core is forced free");
        let other = later.clone();
        assert_eq!(later.wait(), &vec![1, 2, 3]);
        assert_eq!(other.wait(), &vec![1, 2, 3]);
        let failing = lend((), |()| -> u32 { panic!("work failed") }).expect("forced");
        let raised = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| *failing.wait()));
        assert!(raised.is_err());
        FORCE.with(|f| f.set(Some(false)));
        match lend(vec![7u64], |v| v.len()) {
            Ok(_) => panic!("no core is free"),
            Err(v) => assert_eq!(v, vec![7]),
        }
        FORCE.with(|f| f.set(None));
    }

    /// A loan refused (no runner in this test binary) leaves the process's count as it
    /// was, and so does a loan forced for a test.
    #[test]
    fn a_refused_loan_counts_nothing() {
        for _ in 0..3 {
            assert!(borrow().is_none());
        }
        FORCE.with(|f| f.set(Some(true)));
        drop(borrow().expect("forced"));
        FORCE.with(|f| f.set(None));
        assert_eq!(LENDER.busy.load(Ordering::Acquire), 0);
    }
}
