//! How the passes over particle rows use the pool's threads: a static schedule, and
//! threads kept awake for the whole run.
//!
//! A pass's work items (chunks of [`CHUNK`](crate::CHUNK) rows) are cut into one
//! contiguous part per thread of the pool, part `t` always run by thread `t` (as OpenMP's
//! `schedule(static)`). Rayon's work stealing hands out the chunks by timing instead:
//! which thread runs a chunk near the middle of the rows changes from pass to pass, and a
//! chunk that the other core wrote last must then come over from that core's cache. On
//! the Zen 3 of 2026-12-02 (two vCPUs of a virtual machine), a streaming pass whose
//! halves swap threads every pass ran 4.5 times slower than with fixed halves
//! (docs/performance.md). With one fixed part per thread, the passes of a step and the
//! steps find their rows in the cache of the core that ran them last.
//!
//! Passes whose cost per row varies (the contact passes: pairs and walls per particle)
//! cut their parts where the last run's part times say the work is halved
//! ([`PartTimes`]), moving the cuts a few chunks at most from step to step.
//!
//! The reduction combines each part's fold in part order; the passes reduce with
//! order-independent operations (largest values, with ties broken by id), so the
//! results do not depend on the thread count nor on where the parts are cut.
use rayon::iter::plumbing::{Producer, ProducerCallback};
use rayon::iter::IndexedParallelIterator;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Static-schedule drivers for every indexed parallel iterator.
pub trait StaticSplit: IndexedParallelIterator {
    /// `map` over the items, folded with `op` from `identity`: the items cut into equal
    /// parts, each thread folds its own part in order, then the parts are combined in
    /// part order.
    fn static_map_reduce<R, M, Id, Op>(self, map: M, identity: Id, op: Op) -> R
    where
        R: Send,
        M: Fn(Self::Item) -> R + Sync,
        Id: Fn() -> R + Sync,
        Op: Fn(R, R) -> R + Sync,
    {
        // With no times of a last run, the parts are equal.
        self.timed_map_reduce(&mut PartTimes::default(), map, identity, op)
    }

    /// As [`static_map_reduce`](Self::static_map_reduce), the parts cut where the times
    /// of the pass's last run say they take equal time, and this run's times kept for
    /// the next. A pass whose parts took less than [`PARALLEL_SECONDS`] in all runs on
    /// the calling thread alone.
    fn timed_map_reduce<R, M, Id, Op>(
        self,
        times: &mut PartTimes,
        map: M,
        identity: Id,
        op: Op,
    ) -> R
    where
        R: Send,
        M: Fn(Self::Item) -> R + Sync,
        Id: Fn() -> R + Sync,
        Op: Fn(R, R) -> R + Sync,
    {
        let len = self.len();
        let ends = times.next_ends(len, rayon::current_num_threads().clamp(1, len.max(1)));
        let (result, seconds) = self.with_producer(Parts {
            ends: &ends,
            map,
            identity,
            op,
        });
        *times = PartTimes { len, ends, seconds };
        result
    }

    /// `f` on every item, each thread on its own part.
    fn static_for_each<F>(self, f: F)
    where
        F: Fn(Self::Item) + Sync,
    {
        self.static_map_reduce(f, || (), |(), ()| ());
    }
}

impl<I: IndexedParallelIterator> StaticSplit for I {}

/// Below this much work in all (seconds, the parts' times summed) a timed pass runs on
/// one thread: starting the other threads and waiting for the last costs about 3 us
/// (Zen 3, 2026-12-02), so a pass gains from two threads from about twice that.
pub const PARALLEL_SECONDS: f64 = 8e-6;

/// The last run of a timed pass ([`StaticSplit::timed_map_reduce`]): its number of
/// items, where its parts ended (all but the last), and the seconds each part took.
#[derive(Debug, Default, Clone)]
pub struct PartTimes {
    len: usize,
    ends: Vec<usize>,
    seconds: Vec<f64>,
}

impl PartTimes {
    /// The part ends for a run of `len` items on `threads` threads: equal parts at first
    /// (or after the items changed), then each cut moved halfway toward where the last
    /// run's times, spread evenly over the items of each part, reach their share (the
    /// half damps the noise of single timings).
    fn next_ends(&self, len: usize, threads: usize) -> Vec<usize> {
        let total: f64 = self.seconds.iter().sum();
        if self.len == len && total < PARALLEL_SECONDS {
            return Vec::new();
        }
        let known = self.len == len && self.seconds.len() == threads && total > 0.0;
        if !known {
            return (1..threads).map(|t| len * t / threads).collect();
        }
        let bounds: Vec<usize> = std::iter::once(0)
            .chain(self.ends.iter().copied())
            .chain(std::iter::once(len))
            .collect();
        let mut ends = Vec::with_capacity(threads - 1);
        for t in 1..threads {
            let share = total * t as f64 / threads as f64;
            let (mut before, mut at) = (0.0, len as f64);
            for (k, &s) in self.seconds.iter().enumerate() {
                let (b, e) = (bounds[k], bounds[k + 1]);
                if before + s >= share && e > b {
                    at = b as f64 + (share - before) / s * (e - b) as f64;
                    break;
                }
                before += s;
            }
            let old = bounds[t] as f64;
            let cut = (old + 0.5 * (at - old)).round() as usize;
            let floor = ends.last().copied().unwrap_or(0);
            ends.push(cut.clamp(floor, len));
        }
        ends
    }
}

struct Parts<'e, M, Id, Op> {
    /// The end of every part but the last, which ends at the length.
    ends: &'e [usize],
    map: M,
    identity: Id,
    op: Op,
}

impl<M, Id, Op> Parts<'_, M, Id, Op> {
    /// The part folded in order, and the seconds it took.
    fn fold<P, R>(&self, part: P) -> (R, f64)
    where
        P: Producer,
        M: Fn(P::Item) -> R,
        Id: Fn() -> R,
        Op: Fn(R, R) -> R,
    {
        let start = Instant::now();
        let r = part
            .into_iter()
            .map(&self.map)
            .fold((self.identity)(), &self.op);
        (r, start.elapsed().as_secs_f64())
    }
}

impl<T, R, M, Id, Op> ProducerCallback<T> for Parts<'_, M, Id, Op>
where
    R: Send,
    M: Fn(T) -> R + Sync,
    Id: Fn() -> R + Sync,
    Op: Fn(R, R) -> R + Sync,
{
    /// The reduction, and the seconds of each part.
    type Output = (R, Vec<f64>);

    fn callback<P: Producer<Item = T>>(self, producer: P) -> (R, Vec<f64>) {
        if self.ends.is_empty() {
            let (r, s) = self.fold(producer);
            return (r, vec![s]);
        }
        let mut slots = Vec::with_capacity(self.ends.len() + 1);
        let (mut rest, mut at) = (producer, 0);
        for &end in self.ends {
            let (part, tail) = rest.split_at(end - at);
            slots.push(Mutex::new(Some(part)));
            (rest, at) = (tail, end);
        }
        slots.push(Mutex::new(Some(rest)));
        // Every thread of the pool runs this once, with its own index (a pool with more
        // threads than parts leaves the others without one).
        let folds = rayon::broadcast(|ctx| {
            let part = slots.get(ctx.index()).and_then(|s| s.lock().ok()?.take());
            part.map(|p| self.fold(p))
        });
        let (results, seconds): (Vec<R>, Vec<f64>) = folds.into_iter().flatten().unzip();
        let r = results
            .into_iter()
            .reduce(&self.op)
            .unwrap_or_else(&self.identity);
        (r, seconds)
    }
}

/// Keeps the other threads of the pool awake while it lives: each spins, running any
/// work the pool has for it (a part of a static pass, a stolen half of a split), until
/// the guard is dropped, or until it has found no work for [`SPIN_SECONDS`] (a long
/// serial stretch such as writing output, or a driver that stopped stepping: the core is
/// then left to the system, and [`rearm`](Self::rearm) at the next step starts the
/// spinning again).
///
/// An idle rayon worker sleeps after about 50 us without work, and waking it took 10 to
/// 60 us on the Zen 3 of 2026-12-02 (a virtual machine: the wake-up is an interrupt to
/// another virtual CPU; docs/performance.md). A step has passes shorter than that
/// between serial stretches longer than that, so a pass would often start on one thread
/// and wait for the other. The price is a busy core during the serial stretches, as with
/// OpenMP's active wait policy.
pub struct KeepAwake {
    stop: Arc<AtomicBool>,
    /// Threads spinning, or told to and not yet started.
    spinning: Arc<AtomicUsize>,
}

/// A spinning thread that found no work for this long stops spinning (seconds).
pub const SPIN_SECONDS: f64 = 2e-3;

impl KeepAwake {
    /// Starts the spinning on the current pool's other threads: only when called from a
    /// thread of a pool of more than one (as `grainflow run` does, inside its pool); a
    /// caller outside the pool would compete with the spinning threads for the cores.
    pub fn start() -> Self {
        let awake = Self {
            stop: Arc::new(AtomicBool::new(false)),
            spinning: Arc::new(AtomicUsize::new(0)),
        };
        awake.rearm();
        awake
    }

    /// Starts the spinning again if every spinning thread has stopped (cheap when they
    /// spin: one atomic load). Call it from the driving thread, once per step.
    pub fn rearm(&self) {
        let threads = rayon::current_num_threads();
        let Some(driver) = rayon::current_thread_index().filter(|_| threads > 1) else {
            return;
        };
        if self.spinning.load(Ordering::Acquire) > 0 {
            return;
        }
        self.spinning.store(threads - 1, Ordering::Release);
        let (stop, spinning) = (Arc::clone(&self.stop), Arc::clone(&self.spinning));
        rayon::spawn_broadcast(move |ctx| {
            if ctx.index() == driver {
                return;
            }
            let mut idle_since = Instant::now();
            let mut rounds = 0u32;
            while !stop.load(Ordering::Acquire) {
                if rayon::yield_now() == Some(rayon::Yield::Executed) {
                    idle_since = Instant::now();
                    continue;
                }
                rounds = rounds.wrapping_add(1);
                if rounds.is_multiple_of(1024) {
                    if idle_since.elapsed().as_secs_f64() > SPIN_SECONDS {
                        break;
                    }
                    // Something else may wait for the core.
                    std::thread::yield_now();
                } else {
                    std::hint::spin_loop();
                }
            }
            spinning.fetch_sub(1, Ordering::AcqRel);
        });
    }
}

impl Drop for KeepAwake {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    /// Every item is mapped once, on the thread of its part, and the parts are contiguous
    /// and in thread order (a single part runs on the calling thread).
    #[test]
    fn one_contiguous_part_per_thread() {
        for threads in [1, 2, 3, 5] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for len in [0, 1, 2, 7, 100] {
                let mut owner = vec![usize::MAX; len];
                let count = pool.install(|| {
                    owner.par_iter_mut().static_map_reduce(
                        |o| {
                            *o = rayon::current_thread_index().unwrap();
                            1usize
                        },
                        || 0,
                        |a, b| a + b,
                    )
                });
                assert_eq!(count, len, "{threads} threads, {len} items");
                let parts = threads.min(len);
                if parts == 1 {
                    // One part: run by the calling thread, whichever it is.
                    assert!(owner.iter().all(|&o| o == owner[0]));
                    continue;
                }
                for (i, &o) in owner.iter().enumerate() {
                    let part = (0..parts).find(|&t| i < len * (t + 1) / parts).unwrap();
                    assert_eq!(o, part, "{threads} threads, item {i} of {len}");
                }
            }
        }
    }

    /// The cuts follow the part times: equal parts first; a part that took three times
    /// as long as the other gives up items (halfway toward the cut of equal times); a
    /// pass too short for two threads runs on one; new items start equal again.
    #[test]
    fn part_times_move_the_cut() {
        let first = PartTimes::default();
        assert_eq!(first.next_ends(25, 2), [12]);
        let slow_first = PartTimes {
            len: 25,
            ends: vec![12],
            seconds: vec![3e-3, 1e-3],
        };
        // Equal times at 2/3 of part 0 (item 8): halfway from 12 is 10.
        assert_eq!(slow_first.next_ends(25, 2), [10]);
        let slow_last = PartTimes {
            len: 25,
            ends: vec![12],
            seconds: vec![1e-3, 3e-3],
        };
        // Equal times at 12 + 13/3 (16.3): halfway is 14.2.
        assert_eq!(slow_last.next_ends(25, 2), [14]);
        let short = PartTimes {
            len: 25,
            ends: vec![12],
            seconds: vec![1e-6, 1e-6],
        };
        assert!(short.next_ends(25, 2).is_empty());
        assert_eq!(short.next_ends(30, 2), [15]);
        let three = PartTimes {
            len: 30,
            ends: vec![10, 20],
            seconds: vec![1e-3, 1e-3, 1e-3],
        };
        assert_eq!(three.next_ends(30, 3), [10, 20]);
    }

    /// A reduction that is not commutative sees the items in order.
    #[test]
    fn parts_combine_in_order() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let items: Vec<u32> = (0..50).collect();
        let joined = pool.install(|| {
            items.par_iter().static_map_reduce(
                |&i| vec![i],
                Vec::new,
                |mut a, b| {
                    a.extend(b);
                    a
                },
            )
        });
        assert_eq!(joined, items);
    }
}
