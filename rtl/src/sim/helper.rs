//! Two threads working on one round of the windowed run: the caller and one helper thread
//! ([`crate::gpu::Gpu::with_helper_thread`]: the L2's back end and the first SMs here, the other
//! SMs there).
//!
//! [`Helper::join`] is `rayon::join` with one dedicated worker that spins instead of sleeping: a
//! round of the windowed run is little work, often less than a thread pool takes to wake
//! a sleeping worker or a blocked caller, while handing a job to a spinning thread on another
//! core and back costs about 40 ns here (a two-thread ping-pong of one atomic).
//!
//! The caller offers the second job, runs the first, and then takes the second back and runs it
//! itself if the helper has not started it (its core may be busy with another thread, say the
//! tracer): a helper that is late costs the offer, not a wait. Otherwise the caller waits for the
//! helper to finish. Either way each job runs exactly once and `join` returns only when both are
//! done, which is what makes lending the helper a borrowed job sound. A waiting thread spins,
//! yielding its core now and then.
//!
//! Results cannot depend on which thread ran a job: the jobs are given disjoint state (the
//! caller's borrows say so) and the outcome is read in a fixed order.

use std::any::Any;
use std::cell::UnsafeCell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicU8, Ordering};

/// No job offered.
const IDLE: u8 = 0;
/// A job is offered and no one has taken it.
const OFFERED: u8 = 1;
/// The helper is running the job.
const RUNNING: u8 = 2;
/// The helper has finished the job.
const DONE: u8 = 3;
/// The helper is to return.
const EXIT: u8 = 4;

/// Spins before a waiting thread yields its core (about a microsecond of `spin_loop` hints).
const SPINS: u32 = 1 << 10;

/// A job lent to the helper: a pointer to the caller's closure slot and the function that runs
/// it.
#[derive(Clone, Copy)]
struct Offer {
    slot: *const (),
    run: unsafe fn(*const ()),
}

/// The state shared by the caller and its helper thread.
pub struct Helper {
    state: AtomicU8,
    offer: UnsafeCell<Option<Offer>>,
}

// The offer is written by the caller only while the state is IDLE (the helper does not read it
// then) and read by the helper only after it moved the state from OFFERED to RUNNING; the
// release store of OFFERED and the acquire compare-exchange order the two.
unsafe impl Sync for Helper {}

/// What a lent job leaves behind: its closure until it runs, then its result or its panic.
struct Slot<F, R> {
    job: Option<F>,
    result: Option<std::thread::Result<R>>,
}

/// Runs the job in the [`Slot`] at `slot`.
///
/// # Safety
/// `slot` points to a live `Slot<F, R>` that no one else touches during the call.
unsafe fn run_slot<F: FnOnce() -> R, R>(slot: *const ()) {
    let slot = unsafe { &mut *(slot as *mut Slot<F, R>) };
    if let Some(job) = slot.job.take() {
        slot.result = Some(panic::catch_unwind(AssertUnwindSafe(job)));
    }
}

impl Default for Helper {
    fn default() -> Self {
        Helper { state: AtomicU8::new(IDLE), offer: UnsafeCell::new(None) }
    }
}

impl Helper {
    /// The helper thread's loop: runs each job offered until [`Helper::stop`].
    pub fn serve(&self) {
        let mut spins = 0u32;
        loop {
            match self.state.load(Ordering::Acquire) {
                EXIT => return,
                OFFERED => {
                    if self
                        .state
                        .compare_exchange(OFFERED, RUNNING, Ordering::Acquire, Ordering::Relaxed)
                        .is_ok()
                    {
                        // SAFETY: the offer was written before OFFERED was stored (release) and
                        // stays as it is while the state is RUNNING; the caller's `join` waits
                        // for DONE, so the slot outlives this call and no one else touches it.
                        unsafe {
                            let offer = (*self.offer.get()).expect("an offer");
                            (offer.run)(offer.slot);
                        }
                        self.state.store(DONE, Ordering::Release);
                    }
                    spins = 0;
                }
                _ => wait(&mut spins),
            }
        }
    }

    /// Tells the helper thread to return (once it has finished a job it is running).
    pub fn stop(&self) {
        let mut spins = 0u32;
        loop {
            match self.state.compare_exchange(IDLE, EXIT, Ordering::AcqRel, Ordering::Acquire) {
                Ok(_) | Err(EXIT) => return,
                Err(_) => wait(&mut spins),
            }
        }
    }

    /// Runs `a` on this thread and `b` on the helper thread if it takes it in time, else on this
    /// thread after `a`; returns both results once both have run. A panic in either is resumed
    /// here (after both have finished).
    pub fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA,
        B: FnOnce() -> RB + Send,
        RB: Send,
    {
        let mut slot: Slot<B, RB> = Slot { job: Some(b), result: None };
        let offer = Offer { slot: &mut slot as *mut Slot<B, RB> as *const (), run: run_slot::<B, RB> };
        // SAFETY: the state is IDLE (every join leaves it so), so the helper does not read the
        // offer now.
        unsafe { *self.offer.get() = Some(offer) };
        self.state.store(OFFERED, Ordering::Release);
        let ra = panic::catch_unwind(AssertUnwindSafe(a));
        if self.state.compare_exchange(OFFERED, IDLE, Ordering::Acquire, Ordering::Relaxed).is_ok() {
            // Taken back before the helper started it: run it here.
            // SAFETY: the helper never took the offer, so the slot is ours alone.
            unsafe { run_slot::<B, RB>(offer.slot) };
        } else {
            let mut spins = 0u32;
            while self.state.load(Ordering::Acquire) != DONE {
                wait(&mut spins);
            }
            self.state.store(IDLE, Ordering::Release);
        }
        let rb = slot.result.take().expect("the second job ran");
        match (ra, rb) {
            (Ok(ra), Ok(rb)) => (ra, rb),
            (Err(p), _) | (_, Err(p)) => resume(p),
        }
    }
}

fn resume(p: Box<dyn Any + Send>) -> ! {
    panic::resume_unwind(p)
}

/// One step of waiting: a spin hint, and every [`SPINS`] of them the core handed to any other
/// thread that wants it.
#[inline]
fn wait(spins: &mut u32) {
    *spins += 1;
    if spins.is_multiple_of(SPINS) {
        std::thread::yield_now();
    } else {
        std::hint::spin_loop();
    }
}

/// Runs `body` with a helper thread serving `Helper::join` calls, and stops the helper when
/// `body` returns or panics.
pub fn with_helper<R>(body: impl FnOnce(&Helper) -> R) -> R {
    let helper = Helper::default();
    std::thread::scope(|s| {
        s.spawn(|| helper.serve());
        // Stops the helper even if `body` panics (the scope joins it before returning).
        struct Stop<'a>(&'a Helper);
        impl Drop for Stop<'_> {
            fn drop(&mut self) {
                self.0.stop();
            }
        }
        let _stop = Stop(&helper);
        body(&helper)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_jobs_run_once_with_their_borrows() {
        with_helper(|h| {
            let mut left = vec![0u64; 64];
            let mut right = vec![0u64; 64];
            for round in 0..20_000u64 {
                let (ra, rb) = h.join(
                    || {
                        left.iter_mut().for_each(|x| *x += round);
                        round
                    },
                    || {
                        right.iter_mut().for_each(|x| *x += 2 * round);
                        round + 1
                    },
                );
                assert_eq!((ra, rb), (round, round + 1));
            }
            let total: u64 = (0..20_000u64).sum();
            assert!(left.iter().all(|&x| x == total));
            assert!(right.iter().all(|&x| x == 2 * total));
        });
    }

    #[test]
    fn a_panic_in_the_lent_job_reaches_the_caller_after_both_ran() {
        let mut ran_a = false;
        let caught = panic::catch_unwind(AssertUnwindSafe(|| {
            with_helper(|h| h.join(|| ran_a = true, || panic!("lent job failed")))
        }));
        assert!(caught.is_err());
        assert!(ran_a);
    }
}
