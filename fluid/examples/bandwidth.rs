//! Memory bandwidth of this host as the fluid solver's passes see it: STREAM's copy
//! (`c = a`), scale (`b = s c`), add (`c = a + b`) and triad (`a = b + s c`) kernels
//! (McCalpin 1995) over arrays of 512 MiB each (64 Mi doubles, far beyond any cache),
//! run with rayon on 1 and 2 threads in chunks of 1 Mi doubles. Bytes are counted as
//! STREAM counts them (copy and scale 16, add and triad 24 per element: the
//! write-allocate read of the destination is not counted); each figure is the best of
//! `REPS` passes (default 10), as in STREAM.
//!
//!   cargo run --release -p grainflow-fluid --example bandwidth [REPS]

use rayon::prelude::*;
use std::time::Instant;

/// Doubles per array (512 MiB).
const N: usize = 64 << 20;
/// Doubles per parallel task.
const CHUNK: usize = 1 << 20;

/// Best seconds of `reps` runs of `pass`.
fn best(reps: usize, mut pass: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            pass();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .map_or(10, |s| s.parse().expect("REPS: a number"));
    let s = 3.0;
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        pool.install(|| {
            // first touch by the threads that stream them
            let fill = |v: f64| {
                let mut x = vec![0.0f64; N];
                x.par_chunks_mut(CHUNK).for_each(|c| c.fill(v));
                x
            };
            let (mut a, mut b, mut c) = (fill(1.0), fill(2.0), fill(0.0));
            let copy = best(reps, || {
                c.par_chunks_mut(CHUNK)
                    .zip(a.par_chunks(CHUNK))
                    .for_each(|(c, a)| c.copy_from_slice(a))
            });
            let scale = best(reps, || {
                b.par_chunks_mut(CHUNK)
                    .zip(c.par_chunks(CHUNK))
                    .for_each(|(b, c)| b.iter_mut().zip(c).for_each(|(b, c)| *b = s * c))
            });
            let add = best(reps, || {
                c.par_chunks_mut(CHUNK)
                    .zip(a.par_chunks(CHUNK).zip(b.par_chunks(CHUNK)))
                    .for_each(|(c, (a, b))| {
                        c.iter_mut()
                            .zip(a.iter().zip(b))
                            .for_each(|(c, (a, b))| *c = a + b)
                    })
            });
            let triad = best(reps, || {
                a.par_chunks_mut(CHUNK)
                    .zip(b.par_chunks(CHUNK).zip(c.par_chunks(CHUNK)))
                    .for_each(|(a, (b, c))| {
                        a.iter_mut()
                            .zip(b.iter().zip(c))
                            .for_each(|(a, (b, c))| *a = b + s * c)
                    })
            });
            let gbs = |bytes: usize, t: f64| (bytes * N) as f64 / t / 1e9;
            println!(
                "{threads} thread(s): copy {:.1} GB/s, scale {:.1}, add {:.1}, triad {:.1} (check {})",
                gbs(16, copy),
                gbs(16, scale),
                gbs(24, add),
                gbs(24, triad),
                a[N / 3]
            );
        });
    }
}
